set terminal pngcairo size 1000,640 font "sans,11"
set output "samples_error.png"
set title "Position error against sample points, cantilever_coarse"
set xlabel "sample points"
set ylabel "position error (fraction)"
set logscale x
set logscale y
set termoption noenhanced
set grid
set key below
set pointsize 1.2
$s0 << EOD
640 0.189005594 ""
EOD
$s1 << EOD
640 0.137106644 ""
EOD
plot $s0 using 1:2 with linespoints linestyle 1 title "Algorithm 1", \
     $s1 using 1:2 with linespoints linestyle 2 title "Algorithm 2"
