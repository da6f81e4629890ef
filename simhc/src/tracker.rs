//! Path tracker (filled in by the tracker work).
