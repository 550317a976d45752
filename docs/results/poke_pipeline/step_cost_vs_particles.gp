set terminal pngcairo size 1000,640 font "sans,11"
set output "step_cost_vs_particles.png"
set title "poke_cylinder: cost of one step against the particle count"
set xlabel "material points (FOM particles; ROM: the model's points)"
set ylabel "wall seconds per step (ROM: per rollout-step)"
set logscale x
set logscale y
set termoption noenhanced
set grid
set key below
set pointsize 1.2
$s0 << EOD
160 0.000273383507 ""
616 0.000516727627 ""
1368 0.000922866394 ""
4592 0.00307837038 ""
10488 0.00696599696 ""
EOD
$s1 << EOD
1368 0.00192196562 ""
1368 0.00207628507 ""
1368 0.00203887126 ""
1368 0.0070515517 ""
1368 0.00210457468 ""
1368 0.00219511618 ""
1368 0.00228156518 ""
1368 0.00608680924 ""
1368 0.00184414324 ""
1368 0.00215399223 ""
1368 0.00228599875 ""
1368 0.00703221585 ""
1368 0.0022453139 ""
1368 0.00335138983 ""
1368 0.0028404603 ""
1368 0.00736480304 ""
1368 0.0023395156 ""
1368 0.00239679868 ""
1368 0.0027158332 ""
1368 0.0078459628 ""
1368 0.00215433097 ""
1368 0.00228596768 ""
1368 0.00271061288 ""
1368 0.00902371576 ""
1368 0.00459726678 ""
1368 0.00469789674 ""
1368 0.00529798338 ""
1368 0.0172949373 ""
1368 0.00453756718 ""
1368 0.0047124047 ""
1368 0.0049623164 ""
1368 0.0181900894 ""
EOD
plot $s0 using 1:2 with linespoints linestyle 1 title "FOM, scene's cfl", \
     $s1 using 1:2 with points linestyle 2 title "ROM configurations"
