units normalized
bounces unlimited
0 1 1 1 0 # comment

1 1 1 1 1
