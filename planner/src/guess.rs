//! Initial guesses: the equilibrium guess of paper Sec. V (eq. 8) and the zero guess.
