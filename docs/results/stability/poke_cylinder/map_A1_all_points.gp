set terminal pngcairo size 1000,640 font "sans,11"
set output "map_A1_all_points.png"
set title "Stability map, poke_cylinder: A1 all points"
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
0.3 -0.5 "0.191 %" 0.00191067154
1 -0.5 "0.277 %" 0.00277357982
3 -0.5 "0.588 %" 0.0058805712
10 -0.5 "0.588 %" 0.0058805712
0.3 0 "0.237 %" 0.00236699651
1 0 "0.364 %" 0.00363830451
3 0 "0.658 %" 0.00658225407
10 0 "0.658 %" 0.00658225407
0.3 0.5 "0.837 %" 0.00836958075
1 0.5 "0.872 %" 0.00872313079
3 0.5 "1.05 %" 0.0104709103
10 0.5 "1.05 %" 0.0104709103
0.3 1 "1.71 %" 0.0170986027
1 1 "1.73 %" 0.0172762606
3 1 "1.85 %" 0.0184660116
10 1 "1.85 %" 0.0184660116
EOD
$s1 << EOD
EOD
plot $s0 using 1:2:4 with points pt 5 ps 4 lc palette title "stable / inaccurate: colour = position error", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 pt 2 ps 3 title "unstable (detector)"
