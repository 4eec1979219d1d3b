//! Proptest generators shared by all tests (one place, like imageproc's).
