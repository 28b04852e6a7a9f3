#!/bin/bash
# tests/fuzz/campaign.sh "NAMES" SECONDS: the campaign behind reports/fuzz.md. Each harness (after
# make fuzz FUZZ_S=1 has built them and the seeds) for up to 1 M runs or SECONDS, one after
# another, niced, going on after a crash; logs in fuzz/logs/<name>.log, crashes in fuzz/crashes/.
cd "$(dirname "$0")/../.."
for n in $1; do
  mkdir -p fuzz/corpus/$n fuzz/crashes/$n
  LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0 OMP_NUM_THREADS=1 TMPDIR=/dev/shm \
  nice -n 19 ./build-fuzz/fuzz_$n -runs=1000000 -max_total_time=$2 -print_final_stats=1 -artifact_prefix=fuzz/crashes/$n/ \
    fuzz/corpus/$n build/fuzz-seeds/$n > fuzz/logs/$n.log 2>&1
  echo "$n rc=$?" >> fuzz/logs/campaign.txt
done
