set terminal pngcairo size 1000,640 font "sans,11"
set output "map_FOM.png"
set title "Stability map, poke_cylinder: FOM"
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
0.2 -0.5 "0.0417 %" 0.000416972495
0.4 -0.5 "0.0263 %" 0.000263066661
0.6 -0.5 "0.0632 %" 0.000632001112
0.9 -0.5 "0.0923 %" 0.000922806364
0.2 0 "0.0452 %" 0.000451632101
0.4 0 "0.0285 %" 0.000284929796
0.6 0 "0.0684 %" 0.000684493806
0.9 0 "0.0999 %" 0.000999381862
0.2 0.5 "0.0485 %" 0.000485190066
0.4 0.5 "0.0306 %" 0.000306115343
0.6 0.5 "0.0735 %" 0.000735336217
0.9 0.5 "0.107 %" 0.00107346509
0.2 1 "0.0517 %" 0.000517348644
0.4 1 "0.0326 %" 0.000326405747
0.6 1 "0.0784 %" 0.00078398362
0.9 1 "0.114 %" 0.00114438783
EOD
$s1 << EOD
1.2 -0.5 "energy blow-up"
2 -0.5 "energy blow-up"
1.2 0 "energy blow-up"
2 0 "energy blow-up"
1.2 0.5 "energy blow-up"
2 0.5 "energy blow-up"
1.2 1 "energy blow-up"
2 1 "energy blow-up"
EOD
plot $s0 using 1:2:4 with points pt 5 ps 4 lc palette title "stable / inaccurate: colour = position error", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 pt 2 ps 3 title "unstable (detector)", $s1 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle
