# gnuplot script written by tools/figures fig9; drawn by pdr check --plot into the PNG.
# It redraws the same histograms from the .dat beside it.
set terminal png size 900,600
set output 'fig9-tee.png'
set title 'Dihedral angle distribution: tee'
set xlabel 'angle (degrees)'; set ylabel '# elements (x 1000)'
set xrange [0:180]; set xtics 30; set key top right; set style data linespoints
plot 'fig9-tee.dat' using (($1+$2)/2):($3/1000) title 'Boundary elements', \
     '' using (($1+$2)/2):($4/1000) title 'Interior elements'
