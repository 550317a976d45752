set terminal pngcairo size 1000,640 font "sans,11"
set output "map_A2_all_points.png"
set title "Stability map, poke_cylinder: A2 all points"
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
0.3 -0.5 "0.679 %" 0.00679272642
1 -0.5 "0.719 %" 0.00719193624
3 -0.5 "0.885 %" 0.00884504326
10 -0.5 "0.885 %" 0.00884504326
0.3 0 "0.921 %" 0.00920607458
1 0 "1.06 %" 0.010631057
3 0 "1.34 %" 0.0133670419
10 0 "1.34 %" 0.0133670419
0.3 0.5 "1.5 %" 0.0150225602
1 0.5 "1.67 %" 0.0166623395
3 0.5 "1.97 %" 0.0197446394
10 0.5 "1.97 %" 0.0197446394
0.3 1 "2.29 %" 0.0229051058
1 1 "2.45 %" 0.0244785163
3 1 "2.78 %" 0.0278095115
10 1 "2.78 %" 0.0278095115
EOD
$s1 << EOD
EOD
plot $s0 using 1:2:4 with points pt 5 ps 4 lc palette title "stable / inaccurate: colour = position error", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 pt 2 ps 3 title "unstable (detector)"
