set terminal pngcairo size 1000,640 font "sans,11"
set output "map_FOM.png"
set title "Stability map, cantilever_coarse: FOM"
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
0.2 -0.5 "0.205 %" 0.0020478813
0.4 -0.5 "4.87e-14 %" 1e-06
0.6 -0.5 "0.126 %" 0.00126421602
0.2 0 "0.267 %" 0.00266607465
0.4 0 "1.09e-13 %" 1e-06
0.6 0 "0.149 %" 0.00149240279
0.9 0 "0.325 %" 0.00324692555
0.2 0.5 "0.321 %" 0.00321229879
0.4 0.5 "2.23e-13 %" 1e-06
0.6 0.5 "0.18 %" 0.00179656697
0.9 0.5 "0.371 %" 0.00371431186
0.2 1 "0.369 %" 0.00369136029
0.4 1 "1.04e-13 %" 1e-06
0.6 1 "0.212 %" 0.00212303626
0.9 1 "0.437 %" 0.00437229049
EOD
$s1 << EOD
0.9 -0.5 "energy blow-up"
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
