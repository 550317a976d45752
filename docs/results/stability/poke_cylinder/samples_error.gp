set terminal pngcairo size 1000,640 font "sans,11"
set output "samples_error.png"
set title "Position error against sample points, poke_cylinder"
set xlabel "sample points"
set ylabel "position error (fraction)"
set logscale x
set logscale y
set termoption noenhanced
set grid
set key below
set pointsize 1.2
$s0 << EOD
15 0.0172730187 ""
50 0.0219021299 ""
1368 0.00191067154 ""
EOD
$s1 << EOD
6 0.100985686 ""
50 0.0456416558 ""
1368 0.00679272642 ""
EOD
plot $s0 using 1:2 with linespoints linestyle 1 title "Algorithm 1", \
     $s1 using 1:2 with linespoints linestyle 2 title "Algorithm 2"
