//! Inter-process messages and the planner/tracker processes (issue 4).
