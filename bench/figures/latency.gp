set terminal png size 900,560
set output 'latency.png'
set title "Latency tolerance and excess polling, cube-in-cube, 4 PEs"
set xlabel 'injected latency per message'; set ylabel 'latency tolerance (%)'
set y2label 'excess poll time (% of execution)'
set yrange [0:105]; set y2range [0:*]; set ytics nomirror; set y2tics
set key bottom left; set style data linespoints; set offsets 0.3, 0.3, 0, 0
plot 'latency.dat' using 0:3:xtic(1) title 'tolerance, worst PE' lw 2, \
     '' using 0:4 title 'tolerance, average' lw 2, \
     '' using 0:5 axes x1y2 title 'excess poll, worst PE' dt 2 lw 2, \
     '' using 0:6 axes x1y2 title 'excess poll, average' dt 2 lw 2
