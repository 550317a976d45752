set terminal pngcairo size 1000,640 font "sans,11"
set output "map_FOM_max_cfl_0_5.png"
set title "Stability map, cantilever_coarse: FOM max_cfl 0.5"
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
0.6 -0.5 "0.0676 %" 0.000675595285
0.9 -0.5 "0.0676 %" 0.000675595285
1.2 -0.5 "0.0676 %" 0.000675595285
2 -0.5 "0.0676 %" 0.000675595285
0.6 0 "0.0824 %" 0.000823929739
0.9 0 "0.0824 %" 0.000823929739
1.2 0 "0.0824 %" 0.000823929739
2 0 "0.0824 %" 0.000823929739
0.6 0.5 "0.0985 %" 0.000985269188
0.9 0.5 "0.0985 %" 0.000985269188
1.2 0.5 "0.0985 %" 0.000985269188
2 0.5 "0.0985 %" 0.000985269188
0.6 1 "0.116 %" 0.00115509316
0.9 1 "0.116 %" 0.00115509316
1.2 1 "0.116 %" 0.00115509316
2 1 "0.116 %" 0.00115509316
EOD
$s1 << EOD
EOD
plot $s0 using 1:2:4 with points pt 5 ps 4 lc palette title "stable / inaccurate: colour = position error", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 pt 2 ps 3 title "unstable (detector)"
