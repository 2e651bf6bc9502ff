//! Grading curves and the take phase (to be written).
