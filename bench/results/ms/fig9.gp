set terminal pngcairo size 1100,550 font ',10'
set output 'fig9.png'
set datafile separator ','
set logscale xy
set grid
set key top left
set xlabel 'density factor D (sigma_t = 0.05 D per voxel)'
set ylabel 'mean relative extrapolation error'
set title 'Fig. 9: homogeneous sphere (R = 64 voxels), sun +- background, offsets up to 8 voxels'
set key outside right
f(u,b,s) = sprintf("< awk -F, '$2==\"%s\" && $3==\"%s\" && $4==\"%s\"' fig9.csv", u, b, s)
plot f('diagonal','off','seven-point') using 1:5 with linespoints lw 2 dt 1 lc 1 title 'seven-point, sun diagonal', f('diagonal','off','single-gradient') using 1:5 with linespoints lw 2 dt 1 lc 2 title 'single-gradient, sun diagonal', f('diagonal','off','seven-point-euclid') using 1:5 with linespoints lw 2 dt 1 lc 3 title 'seven-point-euclid, sun diagonal', f('diagonal','on','seven-point') using 1:5 with linespoints lw 2 dt 2 lc 1 title 'seven-point, sun diagonal + background', f('diagonal','on','single-gradient') using 1:5 with linespoints lw 2 dt 2 lc 2 title 'single-gradient, sun diagonal + background', f('diagonal','on','seven-point-euclid') using 1:5 with linespoints lw 2 dt 2 lc 3 title 'seven-point-euclid, sun diagonal + background', f('axis','off','seven-point') using 1:5 with linespoints lw 2 dt 3 lc 1 title 'seven-point, sun axis', f('axis','off','single-gradient') using 1:5 with linespoints lw 2 dt 3 lc 2 title 'single-gradient, sun axis', f('axis','off','seven-point-euclid') using 1:5 with linespoints lw 2 dt 3 lc 3 title 'seven-point-euclid, sun axis', f('axis','on','seven-point') using 1:5 with linespoints lw 2 dt 4 lc 1 title 'seven-point, sun axis + background', f('axis','on','single-gradient') using 1:5 with linespoints lw 2 dt 4 lc 2 title 'single-gradient, sun axis + background', f('axis','on','seven-point-euclid') using 1:5 with linespoints lw 2 dt 4 lc 3 title 'seven-point-euclid, sun axis + background'
