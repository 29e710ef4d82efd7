//! ROS 2 bag directories, as `ros2 bag record` writes them: `metadata.yaml`
//! and the bag's files, one or more (a split bag), in SQLite (`.db3`) or MCAP
//! (`.mcap`). The files are taken in the order `metadata.yaml` lists them
//! (`relative_file_paths`); without it, the directory must hold one bag
//! file (several could be unrelated bags).

use std::path::{Path, PathBuf};

use crate::error::Fatal;

/// How a bag directory stores its messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// SQLite (`.db3`), ROS 2's default up to Humble.
    Sqlite,
    /// MCAP (`.mcap`), the default since Iron.
    Mcap,
}

/// The storage and the files, in order, of the bag directory `path`.
///
/// # Errors
/// A [`Fatal`] error when the directory cannot be read, holds no `.db3` or
/// `.mcap` file, or holds both.
pub fn files(path: &Path) -> Result<(Storage, Vec<PathBuf>), Fatal> {
    let name = path.display();
    let listed: Vec<PathBuf> = std::fs::read_to_string(path.join("metadata.yaml"))
        .map(|text| listed_files(&text))
        .unwrap_or_default()
        .into_iter()
        .map(|f| path.join(f))
        .collect();
    let extension = |p: &PathBuf, x: &str| p.extension().is_some_and(|e| e == x);
    let bag_file = |p: &PathBuf| extension(p, "db3") || extension(p, "mcap");
    let files: Vec<PathBuf> = if listed.is_empty() {
        let entries =
            std::fs::read_dir(path).map_err(|e| Fatal::io(format!("{name}: cannot read: {e}")))?;
        let mut found: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(bag_file)
            .collect();
        found.sort();
        if found.len() > 1 {
            return Err(Fatal::usage(format!(
                "{name}: {} bag files and no metadata.yaml to order them: give one file",
                found.len()
            )));
        }
        found
    } else {
        listed.into_iter().filter(bag_file).collect()
    };
    let sqlite = files.iter().filter(|p| extension(p, "db3")).count();
    match (sqlite, files.len()) {
        (_, 0) => Err(Fatal::io(format!(
            "{name}: a directory without a .db3 or .mcap file (a ROS 2 bag directory holds \
             metadata.yaml and its .db3 or .mcap files)"
        ))),
        (0, _) => Ok((Storage::Mcap, files)),
        (n, all) if n == all => Ok((Storage::Sqlite, files)),
        _ => Err(Fatal::io(format!(
            "{name}: both .db3 and .mcap files: give the bag's file to read"
        ))),
    }
}

/// The entries of `relative_file_paths:` in a bag's `metadata.yaml` (a list
/// of `- name` lines under it).
fn listed_files(metadata: &str) -> Vec<String> {
    let mut lines = metadata
        .lines()
        .skip_while(|l| l.trim() != "relative_file_paths:");
    let _ = lines.next();
    lines
        .map_while(|l| l.trim().strip_prefix("- "))
        .map(|f| f.trim().trim_matches(['\'', '"']).to_string())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metadata_lists_the_files_in_order() {
        let text = "rosbag2_bagfile_information:\n  relative_file_paths:\n  - b_0.db3\n  - 'b_1.db3'\n  starting_time:\n";
        assert_eq!(listed_files(text), ["b_0.db3", "b_1.db3"]);
        assert!(listed_files("version: 5\n").is_empty());
    }
}
