//! Mesh readers, one file per format. (Being written.)
