set terminal pngcairo size 1200,450 font ',10'
set output 'fig11_bonsai-ms_sun-sky_320x180.png'
set termoption noenhanced
set datafile missing 'NaN'
set key autotitle columnhead top right
set logscale y
set grid
set xlabel 'time in picvr_step (s)'
set multiplot layout 1,2 title 'bonsai-ms sun-sky 320x180: error from an empty cache, static camera (mean of 2 seeds)'
set ylabel 'true RMSE of luminance vs reference'
plot for [i=2:4] 'fig11_bonsai-ms_sun-sky_320x180.dat' using 1:i with lines lw 2
set ylabel 'estimate: stats.est_error (Eq. 5)'
plot for [i=5:7] 'fig11_bonsai-ms_sun-sky_320x180.dat' using 1:i with lines lw 2
unset multiplot
