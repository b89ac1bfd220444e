# Collision detection speed against collision-point error (vh_eval collision --tsv FILE).
# gnuplot -e "data='collision.tsv'; out='collision.png'" docs/plots/collision.gp
# Columns: method backend viewport threads tris_per_s cp_err_mm_p95 cp_obj_err_mm_p95 d_rec_err_mm_p95 n_hull_err_deg_p95
if (!exists("data")) data = 'collision.tsv'
if (!exists("out")) out = 'collision.png'
set terminal pngcairo size 900,560 font ",10"
set output out
set datafile separator "\t"
set logscale xy
set grid
set key top right
set xlabel "triangles per second (2 cm triangles, 4 cameras 640x480; this 2-core VM)"
set ylabel "collision-point error p95, mm (Hausdorff to the exact contact region)"
set title "hullpipe collision detection: speed against error (paper: 13,000 tris/s at ~2 mm)"
sel(b, t) = (strcol(1) eq "exact" && strcol(2) eq b && column(4) == t)
set label 1 "paper (Onyx2)" at 13000, 2.0 offset 1,0.8
plot data using (sel("cpu", 1) ? $5 : 1/0):6:3 with labels point pt 7 lc rgb "#1f77b4" offset 0,-1 notitle, \
     data using (sel("cpu", 1) ? $5 : 1/0):6 with points pt 7 lc rgb "#1f77b4" title "CPU, 1 thread", \
     data using (sel("cpu", 2) ? $5 : 1/0):6 with points pt 5 lc rgb "#d62728" title "CPU, 2 threads", \
     data using (sel("gl", 1) ? $5 : 1/0):6 with points pt 9 lc rgb "#2ca02c" title "GL (llvmpipe)", \
     "+" using (13000):(2.0) every ::0::0 with points pt 3 ps 2 lc rgb "black" title "paper", \
     "+" using (13000):(0.2) every ::0::0 with points pt 2 ps 2 lc rgb "gray" title "goal: 10x better, same speed"
