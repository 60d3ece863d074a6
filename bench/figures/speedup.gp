set terminal png size 900,560
set output 'speedup.png'
set title "Speed-up over sequential pdr mesh, cube-in-cube, 49094 tetrahedra (2 cores)"
set xlabel 'PEs'; set ylabel 'speed-up'
set logscale x 2; set key top left; set style data linespoints
plot 'speedup.dat' using 1:4 title 'whole command' lw 2, '' using 1:6 title 'refinement stage' lw 2, \
     '' using 1:1 title 'ideal (P)' with lines dt 3, 2 title 'cores' with lines dt 2
