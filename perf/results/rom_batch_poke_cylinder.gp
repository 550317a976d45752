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
1 29.8240199
10 317.778855
100 3248.00449
1000 14526.1052
3000 16411.6409
10000 17171.6939
EOD
$s1 << EOD
1 7152.86477
10 62964.5816
100 382296.583
1000 858502.993
10000 1113197.5
100000 1136890.33
EOD
$s2 << EOD
1 968.197965
10 7808.21082
100 18481.2356
1000 24700.4511
10000 25387.6668
100000 25600.932
EOD
$s3 << EOD
1 5164.77905
10 33764.9621
100 110393.488
1000 248176.274
10000 281344.74
100000 287903.129
EOD
$s4 << EOD
1 333.805318
10 473.87191
100 468.787773
1000 506.274323
EOD
plot $s0 using 1:2 with linespoints lw 2 dt 2 title "PyTorch peer Algorithm 1 (15 samples), NVIDIA H200 PyTorch, float", \
     $s1 using 1:2 with linespoints lw 2 title "mpmrom Galerkin step (30 samples), NVIDIA H200 Cuda, float", \
     $s2 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 2 (15 samples), NVIDIA H200 Cuda, float", \
     $s3 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 1 (15 samples), NVIDIA H200 Cuda, float", \
     $s4 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 1 (15 samples), AMD EPYC OpenMP, double"
