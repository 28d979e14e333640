# SPDX-License-Identifier: Apache-2.0
# The stability-latency study's plot: largest stable P gain (top) and the settling time it gives
# (bottom) over the surface's stiffness, one line per sample-to-drive delay. The CSV's rows are
# surface by surface, three modes each in the study's order: shared tick, paper median, worst.
#   build/default/bench/sim/stability_study --csv study.csv
#   gnuplot -e "csv='study.csv'; png='docs/stability-study.png'" bench/sim/stability_study.gp
if (!exists("csv")) csv = 'study.csv'
if (!exists("png")) png = 'stability-study.png'
set terminal pngcairo size 900,700 font ',10'
set output png
set datafile separator ','
set key top right
set logscale x
set grid
set multiplot layout 2,1 title "PA10 stand-in: what the loop's sample-to-drive delay costs a force loop (lock-step, 2 ms cycle)"
set ylabel 'largest stable gain [m/(s·N)]'
set logscale y
set format y '%.0e'
set xrange [150:200000]
set xtics ('sponge 300' 300, 'rubber 5 000' 5000, 'wood 30 000' 30000, 'steel 100 000' 100000)
plot csv every 3::0 using 2:5 skip 1 with linespoints lw 2 pt 7 title 'shared tick (1 cycle)', \
     csv every 3::1 using 2:5 skip 1 with linespoints lw 2 pt 5 title "paper's processes, median (2 cycles)", \
     csv every 3::2 using 2:5 skip 1 with linespoints lw 2 pt 9 title "paper's processes, worst (3 cycles)"
unset logscale y
set format y '%g'
set ylabel 'settling to ±0.5 N at that gain [s]'
set xlabel 'surface stiffness [N/m]'
set yrange [0:*]
plot csv every 3::0 using 2:7 skip 1 with linespoints lw 2 pt 7 title 'shared tick (1 cycle)', \
     csv every 3::1 using 2:7 skip 1 with linespoints lw 2 pt 5 title "paper's processes, median (2 cycles)", \
     csv every 3::2 using 2:7 skip 1 with linespoints lw 2 pt 9 title "paper's processes, worst (3 cycles)"
unset multiplot
