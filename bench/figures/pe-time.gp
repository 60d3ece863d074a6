set terminal png size 900,560
set output 'pe-time.png'
set title "Where each PE's time went (pe-time.stats)"
set xlabel 'PE'; set ylabel 'seconds'
set style data histograms; set style histogram rowstacked
set style fill solid 0.85 border -1; set boxwidth 0.75
set key outside right top
plot 'pe-time.dat' using 2:xtic(1) title 'cavity work', '' using 3 title 'masked', \
     '' using 4 title 'setback', '' using 5 title 'service', '' using 6 title 'poll', \
     '' using 7 title 'excess poll', '' using 8 title 'idle', '' using ($9 > 0 ? $9 : 0) title 'other'
