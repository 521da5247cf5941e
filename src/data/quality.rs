//! Mesh quality report for `pvrsim info`. (Being written.)
