//! The paper's published numbers, transcribed from its tables and text
//! (`trajopt-paper.tex`): the reference column of every comparison in the reproduction
//! report. `None` is the paper's "NS" (no solution).

/// A published time \[s\] and whether the paper marks it sub-optimal (red); `None` = NS.
pub type TimeCell = Option<(f64, bool)>;
/// (iterations, time \[s\]).
pub type IterTime = (usize, f64);
/// (time \[s\], iterations).
pub type TimeIter = (f64, usize);

/// Table I: CPU time \[s\] per integrator and solver (KNITRO, IPOPT, SNOPT), non-JIT;
/// the flag marks the paper's red (sub-optimal) entries.
pub const TABLE_I: [(&str, [TimeCell; 3]); 9] = [
    (
        "implicit_euler",
        [
            Some((0.087, false)),
            Some((0.535, false)),
            Some((0.686, false)),
        ],
    ),
    ("bdf5", [Some((0.094, false)), Some((0.280, false)), None]),
    (
        "bdf6",
        [
            Some((0.122, false)),
            Some((0.719, false)),
            Some((1.120, false)),
        ],
    ),
    (
        "crank_nicolson",
        [
            Some((0.151, false)),
            Some((0.283, false)),
            Some((0.885, false)),
        ],
    ),
    (
        "bdf4",
        [
            Some((0.231, false)),
            Some((0.201, false)),
            Some((1.630, true)),
        ],
    ),
    (
        "adams_moulton3",
        [
            Some((0.251, false)),
            Some((0.919, false)),
            Some((1.500, false)),
        ],
    ),
    (
        "gauss_legendre2",
        [
            Some((0.847, false)),
            Some((1.212, false)),
            Some((3.070, true)),
        ],
    ),
    ("rk4", [Some((8.539, false)), None, Some((1.870, true))]),
    (
        "rk2",
        [
            Some((1.530, true)),
            Some((7.024, true)),
            Some((1.050, true)),
        ],
    ),
];

/// Fig. 4a as the text states it: max control NRMSE \[%\] bands per integrator.
pub const FIG_4A_NRMSE: [(&str, &str); 4] = [
    ("implicit_euler", "3-5 % (3-4 % with KNITRO)"),
    ("crank_nicolson", "< 1 %"),
    ("gauss_legendre2", "0.1 %"),
    ("bdf4/5/6, adams_moulton3", "larger than Crank-Nicolson"),
];

/// Table II: KNITRO per segment, zero guess (iterations, time \[s\]) and equilibrium
/// ("robust") guess (iterations, time \[s\]).
pub const TABLE_II: [(&str, Option<IterTime>, IterTime); 10] = [
    ("S01", None, (27, 0.073)),
    ("S02", Some((2005, 7.674)), (40, 0.098)),
    ("S03", None, (40, 0.105)),
    ("S04", Some((807, 2.967)), (62, 0.153)),
    ("S05", None, (62, 0.139)),
    ("S06", Some((1227, 5.007)), (35, 0.085)),
    ("S07", Some((693, 2.585)), (39, 0.100)),
    ("S08", Some((202, 0.689)), (66, 0.159)),
    ("S09", Some((1675, 6.542)), (38, 0.091)),
    ("S10", Some((937, 3.763)), (49, 0.136)),
];

/// Table III: per segment from the equilibrium guess, IPOPT with adaptive mu (time \[s\],
/// iterations) and KNITRO with dampmpc (time \[s\], iterations).
pub const TABLE_III: [(&str, TimeIter, TimeIter); 10] = [
    ("S01", (0.406, 82), (0.073, 27)),
    ("S02", (0.178, 36), (0.098, 40)),
    ("S03", (0.415, 102), (0.105, 40)),
    ("S04", (0.485, 111), (0.153, 62)),
    ("S05", (0.461, 101), (0.139, 62)),
    ("S06", (10.714, 129), (0.085, 35)),
    ("S07", (0.783, 90), (0.100, 39)),
    ("S08", (0.323, 76), (0.159, 66)),
    ("S09", (0.324, 61), (0.091, 38)),
    ("S10", (0.570, 81), (0.136, 49)),
];

/// Table IV: KNITRO's barrier rules on the oval (iterations, optimal).
pub const TABLE_IV: [(&str, usize, bool); 6] = [
    ("dampmpc", 22, true),
    ("probing", 29, true),
    ("fullmpc", 29, true),
    ("adaptive", 35, true),
    ("quality", 50, true),
    ("monotone", 289, false),
];

/// Sec. VI-B: max constraint violation of the oval's starting point (unscaled NLP):
/// equilibrium ("robust") guess and zero guess.
pub const INITIAL_VIOLATION: (f64, f64) = (0.9, 6.7e3);

/// Fig. 3 as the text states it: peak stiffness ratio above this, driven by sideslip.
pub const STIFFNESS_PEAK_ABOVE: f64 = 4500.0;
/// The state the paper names as the origin of the stiffness.
pub const STIFFNESS_STATE: &str = "beta";

/// Fig. 4b: the oval from the equilibrium guess, iterations and time \[s\] (JIT).
pub const FIG_4B: (usize, f64) = (22, 0.055);

/// Fig. 5: KNITRO reaches tolerance in fewer than this many iterations on every segment.
pub const FIG_5_MAX_ITERATIONS: usize = 70;

/// Collision avoidance (Sec. VI-D): forgiving case time \[s\] bound, critical case time
/// \[s\] bound and its peak sideslip lower bound \[rad\]; the critical case is infeasible
/// with the tire-saturation constraints.
pub const COLLISION: (f64, f64, f64) = (0.058, 0.072, 0.4);

/// The paper's machine (Sec. VI).
pub const MACHINE: &str = "AMD Ryzen 9 9950X (5.7 GHz), MATLAB R2024b + CasADi, JIT except Table I";
