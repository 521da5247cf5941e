//! (Being written.)
/// x
pub fn write_vtk_legacy(
    _m: &crate::data::TetMesh,
    _p: &std::path::Path,
    _b: bool,
) -> crate::error::Result<()> {
    todo!()
}
