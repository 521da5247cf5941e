//! (Being written.)
/// x
pub fn read(_p: &std::path::Path) -> crate::error::Result<crate::data::TetMesh> {
    todo!()
}
