//! Output machinery every engine shares (DESIGN.md §5): numbers in the 1985 form, the plot
//! font, the provenance of a run, and files written so that a crash never leaves half of one.
//! The 2D engine's writers (PRINT, PLOT, state JSON, VTK, DUMP, SAVE/RESTART) are in
//! `udec::output`.
//!
//! | file | what |
//! |---|---|
//! | [`mod@format`] | numbers in the 1985 `1.234E+05` form |
//! | [`mod@font`] | the font plots caption with |
//! | [`vtk`] | VTK frames (legacy binary, vtkio) and ParaView's `.series` files that list them |
//! | [`provenance`] | what made a run (version, commit, deck, backend, adapter, precision, date): the log's line under the banner and the state JSON's `provenance` |
//!
//! Nothing here reads a model.

pub mod font;
pub mod format;
pub mod provenance;
pub mod vtk;

pub use format::fmt_e;

use std::fs::{self, File};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

/// Writes a file so that a crash or a full disk never leaves a half-written one under `path`:
/// the content goes to a temporary file in the same directory (so the rename cannot cross file
/// systems), is flushed to disk, and is then renamed over `path` in one step, with the mode of
/// the file it replaces. Where `path` is a symbolic link, the file it names is the one replaced
/// and the link stays; where it is not a regular file (a FIFO, a terminal, `/dev/null`,
/// `/proc/self/fd/1`), it is written in place, as a shell's `>` would (see [`destination`]).
/// The writer is buffered; it is seekable where `path` is a regular file (SAVE fills in its
/// header last, and writes it first where it cannot seek).
pub(crate) fn write_atomically(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>) -> io::Result<()> {
    let target = match destination(path) {
        Destination::InPlace(path) => {
            let mut w = BufWriter::new(File::create(path)?);
            write(&mut w)?;
            // No fsync: a pipe or a device has no disk to flush to (and refuses the call).
            return w.into_inner().map(drop).map_err(|e| e.into_error());
        }
        Destination::Replace(target) => target,
    };
    let tmp = temp_path(&target);
    let result = (|| {
        let mut w = BufWriter::new(File::create(&tmp)?);
        write(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        if let Ok(old) = fs::metadata(&target) {
            file.set_permissions(old.permissions())?;
        }
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, &target)
    })();
    if result.is_err() {
        // Best effort: the original error is the one worth reporting.
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// How [`write_atomically`] writes an output.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Destination {
    /// A regular file, or none yet: this file is written beside it and renamed over it. For a
    /// symbolic link it is the file at the end of the link (created if the link dangles, as `>`
    /// does), so that the link is kept.
    Replace(PathBuf),
    /// Anything else (a FIFO, a character device, a directory, a link through `/proc`): this path
    /// opened and written in place. Renaming over it would put a regular file where the pipe or
    /// device was and leave a reader waiting for ever; a directory or a loop of links fails to
    /// open, with the system's reason, and is left as it was.
    InPlace(PathBuf),
}

/// Links followed before giving up (Linux's own limit, ELOOP).
const MAX_LINKS: usize = 40;

/// Where an output to `path` goes (see [`Destination`]). Links are followed one at a time, each
/// relative one from the folder that holds it, as the system resolves them. A link under
/// `/proc` (`/dev/stdout` leads to `/proc/self/fd/1`) stands for a file already open, whose name,
/// if it has one, is not the file: the output is written through it in place.
pub(crate) fn destination(path: &Path) -> Destination {
    let mut at = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        let Ok(meta) = fs::symlink_metadata(&at) else {
            // Nothing there yet (or nothing that can be read: the write reports why).
            return Destination::Replace(at);
        };
        if meta.is_file() {
            return Destination::Replace(at);
        }
        if !meta.file_type().is_symlink() || at.starts_with("/proc") {
            return Destination::InPlace(path.to_path_buf());
        }
        let Ok(link) = fs::read_link(&at) else {
            return Destination::InPlace(path.to_path_buf());
        };
        at = match at.parent() {
            Some(dir) if link.is_relative() => dir.join(link),
            _ => link,
        };
    }
    Destination::InPlace(path.to_path_buf())
}

/// `dir/.name.tmp.PID` beside `dir/name`.
fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp.{}", std::process::id()))
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::io::Write;
    use std::os::unix::fs::symlink;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("blockdem-output-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    /// A regular file or a new one is replaced; a link leads to the file it names (followed
    /// relative to the link's folder, through a chain, created if the link dangles); a FIFO,
    /// a device, a folder, a link through /proc or a loop of links is written in place. Only
    /// `stat` is asked of /dev/null here: nothing under /dev is written.
    #[test]
    fn an_output_replaces_regular_files_and_writes_through_links_and_devices() {
        let dir = temp("destination");
        let replace = |p: PathBuf| Destination::Replace(p);
        assert_eq!(destination(&dir.join("new.sav")), replace(dir.join("new.sav")));
        fs::write(dir.join("old.sav"), "x").unwrap();
        assert_eq!(destination(&dir.join("old.sav")), replace(dir.join("old.sav")));

        fs::create_dir(dir.join("runs")).unwrap();
        fs::write(dir.join("runs/c.sav"), "x").unwrap();
        symlink("b", dir.join("a")).unwrap();
        symlink("runs/c.sav", dir.join("b")).unwrap();
        assert_eq!(destination(&dir.join("a")), replace(dir.join("runs/c.sav")));
        symlink(dir.join("old.sav"), dir.join("runs/up")).unwrap();
        assert_eq!(destination(&dir.join("runs/up")), replace(dir.join("old.sav")));
        symlink("runs/later.sav", dir.join("dangling")).unwrap();
        assert_eq!(destination(&dir.join("dangling")), replace(dir.join("runs/later.sav")));

        let fifo = dir.join("fifo");
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        assert_eq!(destination(&fifo), Destination::InPlace(fifo.clone()));
        symlink("fifo", dir.join("to_fifo")).unwrap();
        assert_eq!(destination(&dir.join("to_fifo")), Destination::InPlace(dir.join("to_fifo")));
        symlink("/proc/self/fd/1", dir.join("stdout")).unwrap();
        assert_eq!(destination(&dir.join("stdout")), Destination::InPlace(dir.join("stdout")));
        assert_eq!(destination(&dir.join("runs")), Destination::InPlace(dir.join("runs")));
        symlink("loop2", dir.join("loop1")).unwrap();
        symlink("loop1", dir.join("loop2")).unwrap();
        assert_eq!(destination(&dir.join("loop1")), Destination::InPlace(dir.join("loop1")));
        assert_eq!(destination(Path::new("/dev/null")), Destination::InPlace("/dev/null".into()));
    }

    /// Writing through a link replaces the file it names, keeps that file's mode and leaves the
    /// link and no temporary file; a folder or a loop of links is an error that changes nothing.
    #[test]
    fn an_output_through_a_link_keeps_the_link_and_the_files_mode() {
        use std::os::unix::fs::PermissionsExt;
        let dir = temp("through_link");
        let (file, link) = (dir.join("state.json"), dir.join("latest.json"));
        symlink("state.json", &link).unwrap();
        write_atomically(&link, |w| w.write_all(b"first")).unwrap();
        fs::set_permissions(&file, fs::Permissions::from_mode(0o600)).unwrap();
        write_atomically(&link, |w| w.write_all(b"second")).unwrap();
        assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(fs::read_to_string(&file).unwrap(), "second");
        assert_eq!(fs::metadata(&file).unwrap().permissions().mode() & 0o777, 0o600);
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 2, "a temporary file left behind");

        fs::create_dir(dir.join("folder")).unwrap();
        assert!(write_atomically(&dir.join("folder"), |w| w.write_all(b"x")).is_err());
        symlink("loop2", dir.join("loop1")).unwrap();
        symlink("loop1", dir.join("loop2")).unwrap();
        assert!(write_atomically(&dir.join("loop1"), |w| w.write_all(b"x")).is_err());
        assert!(fs::symlink_metadata(dir.join("loop1")).unwrap().file_type().is_symlink());
        assert_eq!(fs::read_dir(dir.join("folder")).unwrap().count(), 0);
    }
}

/// The path of a file a command names (SAVE, RESTART): `name`, or `default` where none is given,
/// in the output folder `out_dir` when it names no folder; a path with a folder (`./a.sav`,
/// `runs/a.sav`) or an absolute one is taken as given. Both engines' executors resolve by it.
pub fn resolve_in(out_dir: &std::path::Path, name: Option<&str>, default: &str) -> std::path::PathBuf {
    let p = std::path::Path::new(name.unwrap_or(default));
    if p.is_absolute() || p.components().count() > 1 {
        p.to_path_buf()
    } else {
        out_dir.join(p)
    }
}
