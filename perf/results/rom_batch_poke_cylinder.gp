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
1 25.4894258
10 229.701901
100 2385.90154
1000 13202.3521
10000 16974.9173
EOD
$s1 << EOD
1 534.315905
10 4726.52783
100 17026.7607
1000 21620.0326
10000 22197.1846
100000 22298.8631
EOD
$s2 << EOD
1 702.909871
10 6496.4283
100 46868.5153
1000 119626.54
10000 136948.181
100000 140920.593
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
