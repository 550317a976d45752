set terminal pngcairo size 1000,640 font "sans,11"
set output "map_A1_all_points.png"
set title "Stability map, cantilever_coarse: A1 all points"
set xlabel "time step (CFL number)"
set ylabel "extrapolation beyond the training range (widths; -0.5 = centre)"
set logscale x
set cblabel "position error (fraction)"
set palette rgb 33,13,10
set logscale cb
set termoption noenhanced
set grid
set key below
set pointsize 1.2
$s0 << EOD
0.3 -0.5 "17.3 %" 0.173322248
1 -0.5 "19.9 %" 0.199185515
0.3 0 "30.2 %" 0.3019391
1 0 "32.1 %" 0.320656063
0.3 0.5 "39.8 %" 0.397912956
1 0.5 "41.5 %" 0.415129187
0.3 1 "46.9 %" 0.469033011
1 1 "48.6 %" 0.486189747
EOD
$s1 << EOD
3 -0.5 "energy blow-up"
10 -0.5 "energy blow-up"
3 0 "energy blow-up"
10 0 "energy blow-up"
3 0.5 "energy blow-up"
10 0.5 "energy blow-up"
3 1 "energy blow-up"
10 1 "energy blow-up"
EOD
plot $s0 using 1:2:4 with points pt 5 ps 4 lc palette title "stable / inaccurate: colour = position error", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 pt 2 ps 3 title "unstable (detector)", $s1 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle
