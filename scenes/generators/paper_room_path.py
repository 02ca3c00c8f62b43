"""Prints the 40 EGO lines of scenes/paper_room.ses (paste them after its objects).

Each component is a smooth sum of sines over the 40 steps, scaled to the maxima of the
SESGen paper's Table 1 (|U| 0.030, |V| 0.039, |W| <= 0.044, |alpha|, |beta| 0.8, |gamma| 0.5),
sampled at half-steps so that no value is ever exactly zero.
"""
import numpy as np

N = 40
for k in range(N):
    s = (k + 0.5) / N
    row = (0.030 * np.sin(2 * np.pi * s),                     # U (right)
           0.039 * np.sin(4 * np.pi * s + 0.3),               # V (down)
           0.033 + 0.011 * np.sin(3 * np.pi * s + 0.5),       # W (forward): 0.022-0.044
           -0.8 * np.sin(2 * np.pi * s + 0.9),                # alpha (about x)
           0.8 * np.sin(2 * np.pi * s),                       # beta (about y)
           0.5 * np.cos(2 * np.pi * s + 0.2))                 # gamma (about z)
    print("EGO " + " ".join(f"{round(v, 3):.3f}" for v in row))
