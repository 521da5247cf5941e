//! The built-in demo dataset. (Being written.)
