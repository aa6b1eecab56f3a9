# The engine CT's opacity curve (preset ct-engine) with a grey albedo of 0.9 and
# unlimited bounces: the multiply scattered cache's benchmark (bench/scenes_ms.txt).
density 1
bounces unlimited
0.00  0.9 0.9 0.9  0.00
0.12  0.9 0.9 0.9  0.00
0.35  0.9 0.9 0.9  0.02
0.50  0.9 0.9 0.9  0.08
0.62  0.9 0.9 0.9  0.12
0.70  0.9 0.9 0.9  1.00
1.00  0.9 0.9 0.9  1.00
