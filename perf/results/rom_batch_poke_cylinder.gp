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
1 35.2300713
10 405.269717
100 3681.08161
1000 14224.592
3000 16208.2829
10000 17035.1012
EOD
$s1 << EOD
1 7143.81846
10 64270.4427
100 399917.103
1000 1199349.39
10000 1869977.31
100000 2474742.33
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
1 5155.63718
10 37270.3985
100 109728.94
1000 250597.051
10000 301689.786
100000 310894.094
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
