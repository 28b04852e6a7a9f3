#!/bin/bash
# tests/fuzz/report.sh OUT.md: the table of reports/fuzz.md from the campaign's libFuzzer logs
# (fuzz/logs/<name>.log, written by tests/fuzz/campaign.sh): executions, exec/s, the last
# cov/ft numbers, corpus size, crashes (artifacts in fuzz/crashes/<name>/) per harness.
cd "$(dirname "$0")/../.."
out=$1
{
  echo "| harness | executions | exec/s | cov | ft | corpus | crashes/leaks | seconds |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|"
  for log in fuzz/logs/*.log; do
    n=$(basename "$log" .log)
    case $n in *-first) continue ;; esac
    runs=$(awk '/stat::number_of_executed_units/ {print $2}' "$log")
    eps=$(awk '/stat::average_exec_per_sec/ {print $2}' "$log")
    last=$(grep -E '^#[0-9]+' "$log" | tail -1)
    cov=$(echo "$last" | sed -n 's/.* cov: \([0-9]*\).*/\1/p')
    ft=$(echo "$last" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')
    corp=$(echo "$last" | sed -n 's/.* corp: \([0-9]*\)\/.*/\1/p')
    secs=$(grep -oE 'Done [0-9]+ runs in [0-9]+ second' "$log" | awk '{print $5}')
    crashes=$(grep -cE '^==[0-9]+==ERROR|^SUMMARY: (Address|Undefined|Leak)Sanitizer|deadly signal' "$log")
    echo "| $n | ${runs:-?} | ${eps:-?} | ${cov:-?} | ${ft:-?} | ${corp:-?} | $crashes | ${secs:-?} |"
  done
} > "$out"
