//! Road ahead: curvature k_ref(s), lane bounds e_min(s)/e_max(s), obstacles, segments.
