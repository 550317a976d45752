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
1 37.764475
10 320.808665
100 2971.25504
1000 14274.0812
3000 16374.4324
10000 17220.3761
EOD
$s1 << EOD
1 9559.9879
10 80674.0664
100 442424.006
1000 1937228.14
10000 3046861.87
100000 3749761.96
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
1 5493.67648
10 37860.6258
100 113539.003
1000 263056.124
10000 303625.372
100000 310604.963
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
