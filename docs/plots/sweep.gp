# Speed against error of the plane sweep (vh_eval sweep --tsv FILE).
# gnuplot -e "data='sweep.tsv'; out='sweep.png'" docs/plots/sweep.gp
if (!exists("data")) data = 'sweep.tsv'
if (!exists("out")) out = 'sweep.png'
set terminal pngcairo size 1200,520 font ",10"
set output out
set datafile separator "\t"
set logscale xy
set grid
set key top right
set xlabel "time per frame, ms (320x240 view, 4 cameras, CPU 1 thread or GL on llvmpipe)"
head(b, r) = (column(3) == 320 && column(5) == 4 && strcol(8) eq "none" && strcol(6) eq b && column(7) == r)
front = sprintf("< awk -F'\\t' '$14 == 1' %s | sort -g -t'\t' -k9", data)
set multiplot layout 1,2 title "hullpipe plane sweep: depth error against the exact visual hull"
set ylabel "depth error p95, mm"
plot data using (head("cpu", 0) ? $9 : 1/0):11 with points pt 7 lc rgb "#1f77b4" title "CPU, paper (no refinement)", \
     data using (head("cpu", 8) ? $9 : 1/0):11 with points pt 5 lc rgb "#d62728" title "CPU, refined", \
     data using (head("gl", 0) ? $9 : 1/0):11 with points pt 9 lc rgb "#2ca02c" title "GL, paper", \
     data using (head("gl", 8) ? $9 : 1/0):11 with points pt 11 lc rgb "#ff7f0e" title "GL, refined", \
     front using 9:11 with lines lw 2 lc rgb "black" title "Pareto front"
set ylabel "depth error median, mm"
plot data using (head("cpu", 0) ? $9 : 1/0):10 with points pt 7 lc rgb "#1f77b4" title "CPU, paper", \
     data using (head("cpu", 8) ? $9 : 1/0):10 with points pt 5 lc rgb "#d62728" title "CPU, refined", \
     data using (head("gl", 0) ? $9 : 1/0):10 with points pt 9 lc rgb "#2ca02c" title "GL, paper", \
     data using (head("gl", 8) ? $9 : 1/0):10 with points pt 11 lc rgb "#ff7f0e" title "GL, refined", \
     1 with lines dt 2 lc rgb "gray" title "1 mm goal"
unset multiplot
