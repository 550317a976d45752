set terminal pngcairo size 1000,640 font "sans,11"
set output "batch_throughput.png"
set title "Batch throughput: r3_w16_d5 point_s15_cfl3"
set xlabel "rollouts in the batch"
set ylabel "rollout-steps per second"
set logscale x
set logscale y
set termoption noenhanced
set grid
set key below
set pointsize 1.2
$s0 << EOD
1 505.017029 ""
4 522.037997 ""
16 530.781579 ""
64 542.431532 ""
EOD
plot $s0 using 1:2 with linespoints linestyle 1 title "AMD EPYC (OpenMP)"
