//! Integration tests of the estimation stage (see the individual files for unit tests).
