//! Homotopies H(x, t) between a start and a target system (filled in by the tracker work).
