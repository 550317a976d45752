set terminal pngcairo size 1000,640 font "sans,11"
set output "map_A1_15_samples.png"
set title "Stability map, poke_cylinder: A1 15 samples"
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
0.3 -0.5 "1.73 %" 0.0172730187
1 -0.5 "1.4 %" 0.0140148594
3 -0.5 "0.885 %" 0.00885347383
10 -0.5 "0.885 %" 0.00885347383
0.3 0 "1.01 %" 0.0100637715
1 0 "0.728 %" 0.00727955342
3 0 "0.834 %" 0.00833782483
10 0 "0.834 %" 0.00833782483
0.3 0.5 "1.3 %" 0.0129923452
1 0.5 "1.65 %" 0.0165429124
0.3 1 "2.77 %" 0.0277260093
1 1 "3.58 %" 0.0358238018
EOD
$s1 << EOD
3 0.5 "a sample point left the precomputed node set "
10 0.5 "a sample point left the precomputed node set "
3 1 "a sample point left the precomputed node set "
10 1 "a sample point left the precomputed node set "
EOD
plot $s0 using 1:2:4 with points pt 5 ps 4 lc palette title "stable / inaccurate: colour = position error", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 pt 2 ps 3 title "unstable (detector)", $s1 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle
