//! The reference renderer. (Being written.)
