set terminal pngcairo size 1000,640 font "sans,11"
set output "error_vs_cost.png"
set title "poke_cylinder: error against cost (test runs, against the 2x finer FOM)"
set xlabel "cost: wall seconds per simulated second per run (AMD EPYC)"
set ylabel "position_error (%)"
set logscale x
set logscale y
set termoption noenhanced
set grid
set key below
set pointsize 1.2
$s0 << EOD
0.153094764 0.558544521 "x0.5"
0.434051206 0.715310808 "x0.75"
1.03361036 0.538338402 "x1"
5.17166224 0.162068012 "x1.5"
EOD
$s1 << EOD
2.32543928 2.07223347 ""
2.28353581 2.48652559 ""
7.8977379 0.50654564 ""
0.307316265 1.33599388 ""
0.319419126 2.0531139 ""
0.852153293 0.369848121 ""
2.06544043 6.14387533 ""
2.5603186 2.05735916 ""
7.87608175 0.751233007 ""
0.314343946 5.5875793 ""
0.397664442 2.78157698 ""
1.03107243 0.442430274 ""
2.62025748 2.33789968 ""
2.68441452 1.47308521 ""
3.04173319 1.18591445 ""
8.78747834 0.513343089 ""
0.379485803 1.74810371 ""
1.26332021 0.382786999 ""
5.1489388 3.50191629 ""
5.26164435 1.60235311 ""
5.93374139 0.96597952 ""
19.3703298 0.562119151 ""
0.635259406 3.3161788 ""
0.659736658 2.22384469 ""
0.694724296 1.07759922 ""
2.54661252 0.457858201 ""
EOD
$s2 << EOD
0.307316265 1.33599388 "r3_w16_d5 point_s15_cfl3"
0.694724296 1.07759922 "r5_w32_d5 point_s30_cfl3"
0.852153293 0.369848121 "r3_w16_d5 point_s0_cfl3"
EOD
plot $s0 using 1:2 with linespoints linestyle 1 title "FOM, resolutions (cfl 0.3)", $s0 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle, \
     $s1 using 1:2 with points linestyle 2 title "ROM configurations, Algorithm 1", \
     $s2 using 1:2 with linespoints linestyle 3 title "ROM Pareto front", $s2 using 1:2:3 with labels offset 0.8,0.6 left font ",8" notitle
