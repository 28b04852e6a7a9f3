set terminal pngcairo size 1500,560 font ',10'
set output 'frontier.png'
set multiplot layout 1,3
set logscale x
set xlabel 'wall time per scene [s] (optimisation loop, mean over scenes)'
set grid
set key outside below horizontal maxrows 3
set ylabel 'relit PSNR [dB]'
set title 'relit PSNR [dB] vs wall time (circled: current default)'
plot 'frontier.dat' index 0 using 1:2 with linespoints lw 2 pt 7 title 'materialfusion 64px spp2', \
     'frontier.dat' index 0 using 1:($6 == 1 ? $2 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 0 using 1:2:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 1 using 1:2 with linespoints lw 2 pt 7 title 'materialfusion 128px spp2', \
     'frontier.dat' index 1 using 1:($6 == 1 ? $2 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 1 using 1:2:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 2 using 1:2 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp1', \
     'frontier.dat' index 2 using 1:($6 == 1 ? $2 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 2 using 1:2:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 3 using 1:2 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp2', \
     'frontier.dat' index 3 using 1:($6 == 1 ? $2 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 3 using 1:2:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 4 using 1:2 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp4', \
     'frontier.dat' index 4 using 1:($6 == 1 ? $2 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 4 using 1:2:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 5 using 1:2 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp1', \
     'frontier.dat' index 5 using 1:($6 == 1 ? $2 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 5 using 1:2:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 6 using 1:2 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp2', \
     'frontier.dat' index 6 using 1:($6 == 1 ? $2 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 6 using 1:2:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 7 using 1:2 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp4', \
     'frontier.dat' index 7 using 1:($6 == 1 ? $2 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 7 using 1:2:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle
set ylabel 'albedo PSNR [dB]'
set title 'albedo PSNR [dB] vs wall time (circled: current default)'
plot 'frontier.dat' index 0 using 1:3 with linespoints lw 2 pt 7 title 'materialfusion 64px spp2', \
     'frontier.dat' index 0 using 1:($6 == 1 ? $3 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 0 using 1:3:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 1 using 1:3 with linespoints lw 2 pt 7 title 'materialfusion 128px spp2', \
     'frontier.dat' index 1 using 1:($6 == 1 ? $3 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 1 using 1:3:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 2 using 1:3 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp1', \
     'frontier.dat' index 2 using 1:($6 == 1 ? $3 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 2 using 1:3:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 3 using 1:3 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp2', \
     'frontier.dat' index 3 using 1:($6 == 1 ? $3 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 3 using 1:3:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 4 using 1:3 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp4', \
     'frontier.dat' index 4 using 1:($6 == 1 ? $3 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 4 using 1:3:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 5 using 1:3 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp1', \
     'frontier.dat' index 5 using 1:($6 == 1 ? $3 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 5 using 1:3:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 6 using 1:3 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp2', \
     'frontier.dat' index 6 using 1:($6 == 1 ? $3 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 6 using 1:3:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 7 using 1:3 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp4', \
     'frontier.dat' index 7 using 1:($6 == 1 ? $3 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 7 using 1:3:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle
set ylabel 'ORM PSNR [dB]'
set title 'ORM PSNR [dB] vs wall time (circled: current default)'
plot 'frontier.dat' index 0 using 1:4 with linespoints lw 2 pt 7 title 'materialfusion 64px spp2', \
     'frontier.dat' index 0 using 1:($6 == 1 ? $4 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 0 using 1:4:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 1 using 1:4 with linespoints lw 2 pt 7 title 'materialfusion 128px spp2', \
     'frontier.dat' index 1 using 1:($6 == 1 ? $4 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 1 using 1:4:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 2 using 1:4 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp1', \
     'frontier.dat' index 2 using 1:($6 == 1 ? $4 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 2 using 1:4:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 3 using 1:4 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp2', \
     'frontier.dat' index 3 using 1:($6 == 1 ? $4 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 3 using 1:4:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 4 using 1:4 with linespoints lw 2 pt 7 title 'nvdiffrecmc 64px spp4', \
     'frontier.dat' index 4 using 1:($6 == 1 ? $4 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 4 using 1:4:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 5 using 1:4 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp1', \
     'frontier.dat' index 5 using 1:($6 == 1 ? $4 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 5 using 1:4:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 6 using 1:4 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp2', \
     'frontier.dat' index 6 using 1:($6 == 1 ? $4 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 6 using 1:4:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle, \
     'frontier.dat' index 7 using 1:4 with linespoints lw 2 pt 7 title 'nvdiffrecmc 128px spp4', \
     'frontier.dat' index 7 using 1:($6 == 1 ? $4 : 1/0) with points pt 6 ps 3 lc rgb 'black' notitle, \
     'frontier.dat' index 7 using 1:4:(sprintf('%d', $5)) with labels offset 0,1 font ',8' notitle
unset multiplot
