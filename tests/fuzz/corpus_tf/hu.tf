# HU table
units value
density 0.5
bounces 2
-1000 1 1 1 0
300 1 0.9 0.8 0.5 0.2
2000 1 1 1 1
