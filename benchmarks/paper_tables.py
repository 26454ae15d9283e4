"""The papers' numbers that ``benchmarks/reproduce.py`` sets beside jaxga's, transcribed
from the OCR text of the five papers in ``../shared/papers/`` (one comment per number
or row: table, row, column).

Paper files: 000 = IMGA (Li, Hu, Liu 2021), 001 = AGACD (Hao et al. 2021), 002 = Zhang
Ke-qi's IGA, 003 = MPMGA (Hao et al. 2020), 004 = Zhu & Pan 2024 (checked against the
files' headers). Times are the papers' MATLAB seconds on their
own machines (Zhu: MATLAB R2023a, 2.30 GHz, 4 GB; AGACD / MPMGA: MATLAB r2018a, AMD
Ryzen 5 4500U 2.38 GHz; IMGA: MATLAB R2018b).
"""

from __future__ import annotations

# ---------------------------------------------------------------- Zhu & Pan 2024 (004)
# Table 2 ("Experiment 1's simulation results"), 30 repetitions (section 5: "Repeat the
# experiment 30 times"); per row: average number of successes in 100 initialisation
# attempts, average processing time for a population of 200 (s), population average
# path length, sd of the population average path length. GA = random walk, CGA =
# literature [28]'s 1/d roulette, IGA = directional guidance (Algorithm 1).
ZHU_TABLE2 = {
    ("Map 3", "GA"): (3.5667, 3.0364, 99.4183, 25.4193),   # Table 2, Map 3, GA row
    ("Map 3", "CGA"): (5.4224, 2.0871, 93.6177, 26.8966),  # Table 2, Map 3, CGA row
    ("Map 3", "IGA"): (34.1, 0.4452, 71.3699, 16.3846),    # Table 2, Map 3, IGA row
    ("Map 4", "GA"): (3.033, 4.3500, 115.7864, 27.2270),   # Table 2, Map 4, GA row
    ("Map 4", "CGA"): (4.1225, 4.1708, 102.2958, 27.3611),  # Table 2, Map 4, CGA row
    ("Map 4", "IGA"): (24.1514, 0.7312, 81.2861, 18.9799),  # Table 2, Map 4, IGA row
}
ZHU_TABLE2_RUNS = 30        # section 5, Experiment 1: "Repeat the experiment 30 times"
ZHU_TABLE2_ATTEMPTS = 100   # section 5: "the number of 100 initialization successes"

# Table 4 ("Experiment 2's simulation results"), 30 runs per algorithm and map (section
# 5, Experiment 2), Table 3's settings (popnum 200, N = 50, pc 0.8, pm 0.4, ps 0.4,
# omega 0.7, c1-c3 = 1-3); per row: average path length, its sd, average smoothness
# (eq. 8 fit_2), its sd, minimum path length.
ZHU_TABLE4 = {
    ("Map 3", "GA"): (34.3555, 1.29, 13.6, 3.5487, 33.799),         # Table 4, Map 3, GA
    ("Map 3", "CGA"): (32.254, 0.7173, 10.2333, 1.6955, 31.799),    # Table 4, Map 3, CGA
    ("Map 3", "BGA"): (31.5895, 0.3526, 12.0, 3.5428, 30.9706),     # Table 4, Map 3, BGA
    ("Map 3", "CSAGA"): (31.5873, 0.9156, 12.8333, 2.0356, 30.9706),  # Map 3, CSAGA
    ("Map 3", "BFO"): (31.211, 0.4181, 9.1667, 3.9748, 30.9706),    # Table 4, Map 3, BFO
    ("Map 3", "IGA"): (31.0096, 0.1486, 8.9333, 2.2118, 30.9706),   # Table 4, Map 3, IGA
    # Table 4, Map 4, GA. Its minimum 33.5864 is no a + b * sqrt(2) with integers a, b
    # (the nearest is 18 + 11 sqrt(2) = 33.5563): a misprint, as is BGA's below.
    ("Map 4", "GA"): (37.1787, 3.7141, 20.0667, 5.5456, 33.5864),
    ("Map 4", "CGA"): (33.6244, 2.3946, 13.3, 2.9496, 32.1421),     # Table 4, Map 4, CGA
    # Table 4, Map 4, BGA. Its minimum 30.758 is no a + b * sqrt(2) with integers a, b
    # either (the nearest is 18 + 9 sqrt(2) = 30.7279): not the length of an 8-connected
    # path.
    ("Map 4", "BGA"): (30.7948, 0.5579, 12.9667, 2.6325, 30.758),
    ("Map 4", "CSAGA"): (31.4702, 1.5720, 12.1333, 2.8007, 30.3848),  # Map 4, CSAGA
    ("Map 4", "BFO"): (31.1854, 0.8632, 10.0333, 1.9085, 30.3848),  # Table 4, Map 4, BFO
    ("Map 4", "IGA"): (30.5215, 0.4533, 9.0, 0.6948, 30.3848),      # Table 4, Map 4, IGA
}
ZHU_TABLE4_RUNS = 30        # section 5, Experiment 2: "performed 30 times on four grid maps"

# ------------------------------------------------------------- AGACD, Hao et al. 2021 (001)
# Table 5 ("Test data"): 5 trials per design point of Table 4, then the average fitness.
AGACD_TABLE5 = [
    (0.1386, 0.2398, 0.2551, 0.2132, 0.2398),  # Table 5 row 1 (Table 4 no. 1), avg 0.2173
    (0.2398, 0.2398, 0.2336, 0.2286, 0.2169),  # Table 5 row 2, avg 0.2317
    (0.2582, 0.2337, 0.2378, 0.2337, 0.2132),  # Table 5 row 3, avg 0.2353
    (0.2398, 0.2398, 0.2336, 0.2804, 0.4392),  # Table 5 row 4, avg 0.2866
    (0.2398, 0.2398, 0.1364, 0.2398, 0.1364),  # Table 5 row 5, avg 0.1984
    (0.2857, 0.4392, 0.2112, 0.24, 0.2398),    # Table 5 row 6, avg 0.2832
    (0.2219, 0.2857, 0.1386, 0.2398, 0.2378),  # Table 5 row 7, avg 0.2248
    (0.2398, 0.2378, 0.2398, 0.2114, 0.2398),  # Table 5 row 8, avg 0.2337
    (0.2398, 0.2398, 0.2378, 0.2453, 0.4692),  # Table 5 row 9, avg 0.2864
]
AGACD_TABLE5_AVERAGES = (0.2173, 0.2317, 0.2353, 0.2866, 0.1984, 0.2832, 0.2248, 0.2337,
                         0.2864)  # Table 5, column "Average fitness"
AGACD_EQ31 = (0.24416, 0.00673, 0.00847, -0.00841, 0.00594, 0.01624)  # eq. 31 = Table 5
#                                                                        last row X0..X5
AGACD_BEST = (1, 1, -1, 1, 1)          # 5.2.1: "maximal with X1 = 1, X2 = 1, X3 = -1, ..."
AGACD_PREDICTED = 0.28995              # 5.2.1: "The predicted value is 0.28995"
AGACD_CONFIRMATION = (0.3077, 0.2398, 0.2398, 0.4392, 0.3077)  # 5.2.1, 5 confirmation
#                                                                trials, mean 0.30684
AGACD_DOE_SEEDS = 5                    # 5.2.1: "we performed 5 experiments for each group"

# Table 7 (20 x 20): initial population generation time, evolution time, total (s).
AGACD_TABLE7 = {
    "AGACD": (0.0414, 1.5886, 1.63),   # Table 7, AGACD row (2.54 % initialisation)
    "BGA": (0.3089, 1.6711, 1.98),     # Table 7, BGA row (15.60 % initialisation)
}
# Tables 8 and 9 (20 x 20, 20 runs each, 5.2.5): (mean, sd) of the average fitness, the
# average convergence iteration number and the average program running time (s).
AGACD_TABLE8 = {
    "AGACD": ((0.2952, 0.0798), (60.95, 21.6004), (1.5125, 0.1834)),  # Table 8 / 9, AGACD
    "BGA": ((0.2072, 0.0639), (170.3, 100.788), (1.9508, 0.4922)),    # Table 8 / 9, BGA
}
AGACD_TABLE8_BEST = {"AGACD": 0.4392, "BGA": 0.3431}  # 5.2.5 (Fig. 8): best fitness of
#                                                       the 20 runs of each algorithm
AGACD_TABLE8_WINS = 18                 # 5.2.5 (Fig. 8): AGACD beats BGA in 18 of 20 runs
AGACD_RUNS = 20                        # 5.2.5 / 5.3.5: "each algorithm is simulated 20 times"

# Table 11 (50 x 50): initial population generation time, evolution time, total (s).
AGACD_TABLE11 = {
    "AGACD": (0.9777, 8.664, 9.6417),     # Table 11, AGACD row (10.14 %)
    "MPMGA": (53.6721, 9.0143, 62.6864),  # Table 11, MPMGA row (85.62 %)
    "BGA": (43.3714, 9.3021, 52.6735),    # Table 11, BGA row (82.34 %)
}
# Tables 12 and 13 (50 x 50, 20 runs each, 5.3.5): (mean, sd) as Tables 8-9.
AGACD_TABLE12 = {
    "AGACD": ((0.5197, 0.0426), (111.9, 48.4886), (10.16, 1.1732)),    # Tables 12 / 13
    "MPMGA": ((0.4356, 0.0514), (217.25, 62.3849), (55.69, 8.3968)),   # Tables 12 / 13
    "BGA": ((0.3065, 0.0208), (327.2, 84.6433), (49.13, 5.9017)),      # Tables 12 / 13
}
AGACD_TABLE12_BEST = {"AGACD": 0.5634, "BGA": 0.3376}  # 5.3.5 (Fig. 14): best fitness
AGACD_TABLE12_WINS = {"BGA": 20, "MPMGA": 17}  # 5.3.5 (Fig. 14): AGACD beats BGA in 20
#                                                and MPMGA in 17 of 20 runs

# ---------------------------------------------------------- MPMGA, Hao et al. 2020 (003)
# Table 3 (25 x 25 library map): initial population generation time, evolution time,
# second optimisation time, total time (s); None = "-" (no optimisation operator).
MPMGA_TABLE3 = {
    "MPMGA": (1.4153, 1.2616, 0.136, 2.8129),  # Table 3, MPMGA row (50.31 %)
    "PCDA": (0.8494, 1.1891, None, 2.0385),    # Table 3, PCDA row (41.67 %)
    "SGA": (1.0065, 1.2797, None, 2.2862),     # Table 3, SGA row (44.03 %)
}
# Table 6 (50 x 50 artificial map), same columns.
MPMGA_TABLE6 = {
    "MPMGA": (102.7476, 18.8514, 0.241, 121.84),  # Table 6, MPMGA row (84.33 %)
    "PCDA": (79.2217, 20.1283, None, 99.35),      # Table 6, PCDA row (79.74 %)
    "SGA": (84.7192, 19.4608, None, 104.18),      # Table 6, SGA row (81.32 %)
}
# 5.2.2 (Fig. 15): the generation around which each algorithm's best fitness converges.
MPMGA_CONVERGENCE = {"MPMGA": 50, "PCDA": 85, "SGA": 175}
MPMGA_SGA_STALL = 120   # 5.2.2 (Fig. 16): "After the 120th generation, the diversity of
#                         the entire population [SGA] is zero"
MPMGA_RUNS = 20         # 5.2.4 / 5.3.4: "each algorithm is simulated 20 times"
# Tables 4, 5 and 7: only their headers survive in our copy (5.2.4: "Fitness, Length (m),
# Convergence Iterations, Running Time (s), Smoothness"); the text says MPMGA is better
# than PCDA and SGA in average fitness, path length, smoothness and convergence
# iterations, and worse in running time (5.2.4 under Table 4; 5.3.4 for Table 7).
MPMGA_CLAIMS = (
    # (quantity, direction of MPMGA against SGA: "higher" / "lower")
    ("average fitness (MPMGA eq. 3)", "higher"),
    ("average path length", "lower"),
    ("average smoothness (eq. 13 penalty)", "lower"),
    ("average convergence iterations", "lower"),
    ("average running time", "higher"),
)

# ------------------------------------------------------ IMGA, Li, Hu, Liu 2021 (000)
# Table 3 (environment 4, literature [37]'s map): optimal path length, number of turns,
# number of tangencies with obstacles.
IMGA_TABLE3 = {
    "GA": (35.7990, 20, 10),              # Table 3, GA row
    "Literature [37]": (29.7990, 13, 8),  # Table 3, literature [37] row
    "IMGA": (29.6896, 7, 3),              # Table 3, IMGA row
}
IMGA_TABLE4 = {"IMGA": (27.8721, 0.7016), "BCA": (29.9416, 136.4794)}  # Table 4, env. 5:
#                                          optimal path length, optimal running time (s)
IMGA_RUNS = 30          # not given for Table 3 ("multiple simulation experiments", 5.2);
#                         Table 4's count (5.2: "independently executed 30 times")

# ----------------------------------------------------------------- Zhang Ke-qi (002)
# Table 1: three environments, 45 / 40 / 35 iterations, "ordinary" and "improvement"
# rows; the columns (path length, number of turns, 45-, 90-, 135-degree angles) are
# garbled in our copy: every cell of a row repeats one number (14.01, 7, 0, 2, 2, 13.38).
ZHANG_ITERATIONS = (45, 40, 35)   # Table 1, "The number of iterations", environments 1-3
ZHANG_RUNS = 30                   # not given in the paper
ZHANG_CLAIMS = (                  # "Result and Discussion", the sentence under Table 1
    ("path length", "lower"),
    ("number of turns", "lower"),
)
