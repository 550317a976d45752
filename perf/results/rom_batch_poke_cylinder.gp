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
1 31.8322822
10 312.824763
100 2986.39226
1000 14349.8729
3000 16353.4607
10000 17170.2073
EOD
$s1 << EOD
1 7232.97877
10 62805.3349
100 310307.535
1000 411004.559
10000 492416.162
100000 504918.207
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
1 4966.53046
10 37698.9605
100 110094.218
1000 247528.245
10000 280753.667
100000 286424.815
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
