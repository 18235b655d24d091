//! ParaView data collections (`.pvd`): a time series of dataset files, each with its time.
//! Open the `.pvd` in ParaView to step through the frames with the simulated time.

use std::io::{self, Write};

use super::vtu::escape;

/// Writes a collection listing `(time, file)` pairs in the given order; `file` is relative to
/// the `.pvd` file's folder.
pub fn write_pvd(w: &mut dyn Write, entries: &[(f64, &str)]) -> io::Result<()> {
    writeln!(w, r#"<?xml version="1.0"?>"#)?;
    writeln!(
        w,
        r#"<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">"#
    )?;
    writeln!(w, "  <Collection>")?;
    for (t, file) in entries {
        writeln!(
            w,
            r#"    <DataSet timestep="{t:?}" group="" part="0" file="{}"/>"#,
            escape(file)
        )?;
    }
    writeln!(w, "  </Collection>")?;
    writeln!(w, "</VTKFile>")
}
