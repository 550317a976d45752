set terminal pngcairo size 1000,700
set output "rom_batch_poke_cylinder.png"
set title "Batch rollouts, poke_cylinder: rollout-steps/s against batch size"
set xlabel "rollouts in the batch"
set ylabel "rollout-steps per second"
set logscale x
set logscale y
set termoption noenhanced
set grid
set key below
set format y "%.0e"
$s0 << EOD
1 43.96412
10 467.072145
100 4136.34878
1000 14721.4096
10000 17127.6137
EOD
$s1 << EOD
1 579.508451
10 5316.47797
100 17261.3653
1000 21772.5124
EOD
$s2 << EOD
1 805.323348
10 8376.82388
100 50612.8745
1000 120657.124
EOD
$s3 << EOD
1 488.784354
10 502.935917
100 504.053073
1000 507.887042
EOD
plot $s0 using 1:2 with linespoints lw 2 dt 2 title "PyTorch peer Algorithm 1, NVIDIA H200 PyTorch, float", \
     $s1 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 2, NVIDIA H200 Cuda, float", \
     $s2 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 1, NVIDIA H200 Cuda, float", \
     $s3 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 1, AMD EPYC OpenMP, double"
