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
1 36.8148333
10 356.098429
100 3328.3976
1000 14610.0491
10000 17173.049
EOD
$s1 << EOD
1 968.197965
10 7808.21082
100 18481.2356
1000 24700.4511
10000 25387.6668
100000 25600.932
EOD
$s2 << EOD
1 5267.33711
10 36300.923
100 110817.53
1000 260271.859
10000 294411.812
100000 301807.15
EOD
$s3 << EOD
1 333.805318
10 473.87191
100 468.787773
1000 506.274323
EOD
plot $s0 using 1:2 with linespoints lw 2 dt 2 title "PyTorch peer Algorithm 1, NVIDIA H200 PyTorch, float", \
     $s1 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 2, NVIDIA H200 Cuda, float", \
     $s2 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 1, NVIDIA H200 Cuda, float", \
     $s3 using 1:2 with linespoints lw 2 title "mpmrom Algorithm 1, AMD EPYC OpenMP, double"
