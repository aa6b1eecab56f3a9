set terminal pngcairo size 800,500 font ',10'
set output 'fig10_bonsai_paper1_320x180.png'
set termoption noenhanced
set datafile missing 'NaN'
set key autotitle columnhead top right
set logscale y
set grid
set xlabel 'time in picvr_step (s)'
set ylabel 'error of luminance'
set title 'bonsai_paper1_320x180: camera turns 360 degrees in 8.0 s, then stops (mean of 1 seeds)'
set arrow from 8.000, graph 0 to 8.000, graph 1 nohead dt 2
plot 'fig10_bonsai_paper1_320x180.dat' using 1:2 with lines lw 2 title 'plain: true RMSE', '' using 1:3 with lines lw 2 title 'object cache: true RMSE', '' using 1:4 with lines dt 3 title 'plain: est_error', '' using 1:5 with lines dt 3 title 'object cache: est_error'
