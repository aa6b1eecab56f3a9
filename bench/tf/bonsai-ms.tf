# The bonsai CT's opacity curve (preset ct-bonsai) with a grey albedo of 0.9 and
# unlimited bounces: the multiply scattered cache's benchmark (bench/scenes_ms.txt).
density 1
bounces unlimited
0.00  0.9 0.9 0.9  0.00
0.19  0.9 0.9 0.9  0.00
0.27  0.9 0.9 0.9  0.50
0.42  0.9 0.9 0.9  0.85
0.52  0.9 0.9 0.9  1.00
1.00  0.9 0.9 0.9  1.00
