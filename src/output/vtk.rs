//! The VTK chassis both engines write their frames with (DESIGN.md §5): legacy binary `.vtk`
//! files through vtkio, written atomically, and ParaView's JSON file series (`*.series`) that
//! lists a folder's frames with their simulated times, so that a run opens in ParaView as one
//! time-dependent data set. Frames are named `<kind>_<cycle>.vtk` (nine digits), so a RESTART
//! that goes on writes new ones beside the old, and one that goes back replaces the frames after
//! it (the series keeps the frames before its cycle).

use std::path::Path;

use vtkio::model::{ByteOrder, DataSet, PolyDataPiece, Version, Vtk};

/// Writes `vtk` to `path` as a legacy binary file, atomically.
pub fn write_vtk(path: &Path, vtk: Vtk) -> Result<(), String> {
    super::write_atomically(path, |w| vtk.write_legacy(w).map_err(|e| std::io::Error::other(e.to_string())))
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// A legacy (4.2) poly-data file of one piece, titled.
pub fn poly_data(title: &str, piece: PolyDataPiece) -> Vtk {
    Vtk { version: Version::new_legacy(4, 2), title: title.into(), byte_order: ByteOrder::BigEndian, data: DataSet::inline(piece), file_path: None }
}

/// One frame of a `.series` file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeriesFrame {
    pub name: String,
    pub time: f64,
}

/// ParaView's file series (`*.series`, JSON): the frames in order of time.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Series {
    #[serde(rename = "file-series-version")]
    pub version: String,
    pub files: Vec<SeriesFrame>,
}

/// The cycle a frame's file name carries (`blocks_000000100.vtk` → 100).
fn frame_cycle(name: &str) -> Option<u64> {
    name.rsplit_once('_')?.1.strip_suffix(".vtk")?.parse().ok()
}

/// Lists `name` (the frame at `cycle`) in the series file at `path`: frames of later cycles
/// there (a run restarted from an earlier state) are dropped, one of the same cycle replaced.
/// A series file that cannot be read is started again.
pub fn add_to_series(path: &Path, name: &str, cycle: u64, time: f64) -> Result<(), String> {
    let mut series = std::fs::read(path)
        .ok()
        .and_then(|bytes| serde_json::from_slice::<Series>(&bytes).ok())
        .unwrap_or_else(|| Series { version: "1.0".into(), files: Vec::new() });
    series.files.retain(|f| frame_cycle(&f.name).is_some_and(|c| c < cycle));
    series.files.push(SeriesFrame { name: name.into(), time });
    super::write_atomically(path, |w| serde_json::to_writer_pretty(&mut *w, &series).map_err(std::io::Error::other))
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}
