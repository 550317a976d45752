set terminal pngcairo size 1000,640 font "sans,11"
set output "map_A2_all_points.png"
set title "Stability map, cantilever_coarse: A2 all points"
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
0.3 1 "28.6 %" 0.285530744
1 1 "31.2 %" 0.312109263
EOD
$s1 << EOD
0.3 -0.5 "energy blow-up"
1 -0.5 "energy blow-up"
3 -0.5 "energy blow-up"
10 -0.5 "energy blow-up"
0.3 0 "energy blow-up"
1 0 "energy blow-up"
3 0 "energy blow-up"
10 0 "energy blow-up"
0.3 0.5 "a sample point left the precomputed node set "
1 0.5 "a sample point left the precomputed node set "
3 0.5 "energy blow-up"
10 0.5 "energy blow-up"
3 1 "energy blow-up"
10 1 "energy blow-up"
EOD
plot $s0 using 1:2:4 with points pt 5 ps 4 lc palette title "stable / inaccurate: colour = position error", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 pt 2 ps 3 title "unstable (detector)", $s1 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle
