//! The diagnosis engine ([`crate::diagnose::fit`]) on footage rendered and measured through the
//! real chain ([`super::simulate::RenderDetect`]): what needs a detector to test.

use crate::diagnose::fit::*;
use crate::scenario::effects::Effect;

mod backfit_tests;
mod clearance_free_tests;
mod test_footage;
