//! MCAP recording and replay (issue 5).
