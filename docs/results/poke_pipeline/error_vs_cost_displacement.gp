set terminal pngcairo size 1000,640 font "sans,11"
set output "error_vs_cost_displacement.png"
set title "poke_cylinder: error against cost (test runs, against the 2x finer FOM)"
set xlabel "cost: wall seconds per simulated second per run (AMD EPYC)"
set ylabel "displacement_error (%)"
set logscale x
set logscale y
set termoption noenhanced
set grid
set key below
set pointsize 1.2
$s0 << EOD
0.153094764 5.53975236 "x0.5"
0.434051206 7.09459066 "x0.75"
1.03361036 5.33934418 "x1"
5.17166224 1.60742182 "x1.5"
EOD
$s1 << EOD
2.32543928 20.5528115 ""
2.28353581 24.6618407 ""
7.8977379 5.02401743 ""
0.307316265 13.2506452 ""
0.319419126 20.36318 ""
0.852153293 3.66822505 ""
2.06544043 60.9361414 ""
2.5603186 20.4052853 ""
7.87608175 7.45087396 ""
0.314343946 55.4186899 ""
0.397664442 27.5882173 ""
1.03107243 4.38810885 ""
2.62025748 23.1877402 ""
2.68441452 14.6103434 ""
3.04173319 11.7621284 ""
8.78747834 5.09143583 ""
0.379485803 17.33803 ""
1.26332021 3.79655534 ""
5.1489388 34.7326817 ""
5.26164435 15.8924474 ""
5.93374139 9.58077132 ""
19.3703298 5.57520623 ""
0.635259406 32.8905014 ""
0.659736658 22.0565208 ""
0.694724296 10.6878371 ""
2.54661252 4.54112601 ""
EOD
$s2 << EOD
0.307316265 13.2506452 "r3_w16_d5 point_s15_cfl3"
0.694724296 10.6878371 "r5_w32_d5 point_s30_cfl3"
0.852153293 3.66822505 "r3_w16_d5 point_s0_cfl3"
EOD
plot $s0 using 1:2 with linespoints linestyle 1 title "FOM, resolutions (cfl 0.3)", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 title "ROM configurations, Algorithm 1", \
     $s2 using 1:2 with linespoints linestyle 3 title "ROM Pareto front", $s2 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle
