//! The command line: `hybrid render`, `series`, `merge`, `parity`,
//! `report`, `rays export` and `bench`.
//!
//! Every failure becomes one line on stderr naming what and where, and exit
//! code 2; nothing is written under the output name unless the render
//! succeeded.

/// Prints a line to stdout; a closed pipe (`hybrid ... | head`) is not an
/// error worth a panic.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

mod bench;
mod merge;
mod parity;
mod progress;
mod render;
mod report;
mod series;
mod settings;

use std::path::{Path, PathBuf};

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::error::ErrorKind;
use clap::{Parser, Subcommand};

use crate::choice::Choice;
use crate::scene::{builtin, collada, NormalMode, Scene};

#[derive(Parser, Debug)]
#[command(
    name = "hybrid",
    version,
    about = "Path tracer with two acceleration backends: an in-house SAH BVH and Embree"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene to an image.
    Render(render::RenderArgs),
    /// Compare every backend on the same rays (`--hard`: numerical hard cases).
    Parity(parity::ParityArgs),
    /// Measure both backends and write the comparison report.
    Report(report::ReportArgs),
    /// Combine partial renders (-p cells, --samples ranges) into one image.
    Merge(merge::MergeArgs),
    /// Render one scene over a list of values of one option into a
    /// labelled contact sheet (a write-up's figure in one command).
    Series(series::SeriesArgs),
    /// Export the report's ray sets and a scene's triangles as files
    /// (`rays export DIR SCENE`).
    Rays(bench::RaysArgs),
    /// Replay exported ray sets on every backend, one thread, against
    /// Embree called as a plain C program calls it.
    Bench(bench::BenchArgs),
}

/// On SIGINT, SIGTERM or SIGHUP: remove the temporary files of any write
/// in progress and exit with 128 + the signal's number, as the shell would
/// report a process the signal killed.
fn clean_up_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            crate::render::film::abandon_writes();
            std::process::exit(128 + signal);
        }
    });
}

/// The most characters of one error or warning line: errors quote what
/// they found in short (`crate::input::quote`), and this bounds the rest.
const MAX_LINE: usize = 400;

/// Writes one `hybrid: KIND: message` line to stderr: on one line, at most
/// [`MAX_LINE`] characters, and nothing if stderr cannot be written (a
/// full or closed stderr must not turn an error into a panic).
pub fn report_line(kind: &str, message: &str) {
    use std::io::Write;
    let flat = message.replace(['\n', '\r'], " ");
    let prefix = format!("hybrid: {kind}: ");
    // The cap is the whole line's, prefix and the note of a cut included.
    let room = MAX_LINE.saturating_sub(prefix.chars().count());
    let line = if flat.chars().count() <= room {
        flat
    } else {
        let note = format!("… ({} bytes in all)", flat.len());
        let keep = room.saturating_sub(note.chars().count());
        let end = flat.char_indices().nth(keep).map_or(flat.len(), |(i, _)| i);
        format!("{}{note}", &flat[..end])
    };
    let _ = writeln!(std::io::stderr().lock(), "{prefix}{line}");
}

/// Parses a command line (without the program's name) and checks what can
/// be checked before any work: clap's parse, then a render's settings, a
/// series' plan (every tile's options, every output name) and an export's
/// memory and folder. The fuzz target `cli` feeds it arbitrary arguments.
pub fn check_command_line(args: &[String]) -> Result<(), String> {
    let cli =
        Cli::try_parse_from(std::iter::once("hybrid".to_string()).chain(args.iter().cloned()))
            .map_err(|e| one_line(&e.render().to_string()))?;
    match cli.command {
        Command::Render(args) => args.settings().map(|_| ()).map_err(String::from),
        Command::Series(series) => {
            let raw: Vec<std::ffi::OsString> = args.iter().skip(1).map(Into::into).collect();
            series::check(&series, &raw)
        }
        Command::Rays(rays) => bench::check_rays(&rays),
        _ => Ok(()),
    }
}

/// Runs the program; returns the exit code.
pub fn main() -> i32 {
    clean_up_on_signals();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // Help and version as clap prints them; `hybrid` alone shows help.
        Err(e)
            if !e.use_stderr()
                || e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            let _ = e.print();
            return if e.use_stderr() { 2 } else { 0 };
        }
        Err(e) => {
            // Lossy: only read for the message; a non-UTF-8 argument
            // (a Latin-1 file name) must not panic here.
            let args: Vec<String> = std::env::args_os()
                .skip(1)
                .map(|a| a.to_string_lossy().into_owned())
                .collect();
            let message = match unknown_course_flag(&e, &args) {
                Some(message) => message,
                None => one_line(&e.render().to_string()),
            };
            report_line("error", &message);
            return 2;
        }
    };
    if let Err(message) = crate::simd::cpu::Isa::check_variable() {
        report_line("error", &message);
        return 2;
    }
    let outcome = match cli.command {
        Command::Render(args) => render::run(&args).map(|()| true),
        Command::Parity(args) => parity::run(&args),
        Command::Report(args) => report::run(&args).map(|()| true),
        Command::Merge(args) => merge::run(&args).map(|()| true),
        Command::Rays(args) => bench::run_rays(&args).map(|()| true),
        Command::Bench(args) => bench::run_bench(&args).map(|()| true),
        Command::Series(args) => {
            let raw: Vec<std::ffi::OsString> = std::env::args_os().skip(2).collect();
            series::run(&args, &raw).map(|()| true)
        }
    };
    match outcome {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(message) => {
            report_line("error", &message);
            2
        }
    }
}

/// Flags of the course frameworks' renderers that `hybrid` does not take,
/// and what it offers instead.
const COURSE_FLAGS: [(&str, &str); 5] = [
    ("-x", "the ambient-occlusion radius of an older course framework; hybrid has no ambient-occlusion mode: `--normals` checks geometry, `-m 1` renders direct light"),
    ("-g", "the number of images to generate; hybrid renders one image per run: run it once per --seed, or split one frame with --samples A..B and `hybrid merge`"),
    ("-R", "ReSTIR; hybrid's direct-light estimators are --estimator mis|light|hemisphere"),
    ("-w", "a window size; hybrid has no window: -r W H sets the image size and -f FILE the output"),
    ("-i", "interactive mode; hybrid has no window: it renders to -f FILE (PNG or EXR)"),
];

/// The course's flags that `hybrid render` takes, for the message about one
/// it does not.
const COURSE_FLAGS_TAKEN: &str = "-s -l -t -m -o -e -b -d -c -f -r -p -a -H";

/// A message for an unknown flag that a student may have typed from the
/// course (`args`: the command line after the program's name): the
/// command the course's options belong to, or what `hybrid render`
/// offers instead, in place of clap's generic hint.
fn unknown_course_flag(e: &clap::Error, args: &[String]) -> Option<String> {
    use clap::error::{ContextKind, ContextValue};
    if e.kind() != ErrorKind::UnknownArgument {
        return None;
    }
    let Some(ContextValue::String(arg)) = e.get(ContextKind::InvalidArg) else {
        return None;
    };
    let command = args.first().map(String::as_str);
    if !matches!(
        command,
        Some("render" | "parity" | "report" | "merge" | "series" | "help")
    ) {
        // The course's `pathtracer -t 8 -s 64 scene.dae`.
        return Some(format!(
            "unexpected argument '{arg}': the course's options go after a command: hybrid render {}",
            args.join(" ")
        ));
    }
    if !matches!(command, Some("render" | "series")) {
        return None;
    }
    // `-x5` and `-x` are the same flag.
    let flag: String = arg.chars().take(2).collect();
    if arg.starts_with("--") || flag.len() < 2 {
        return None;
    }
    let offered = COURSE_FLAGS
        .iter()
        .find(|(f, _)| *f == flag)
        .map(|(_, instead)| format!(" ({instead})"))
        .unwrap_or_default();
    Some(format!(
        "unknown option '{flag}'{offered}; hybrid render takes the course's {COURSE_FLAGS_TAKEN}, and long options for the rest (see hybrid render --help)"
    ))
}

/// clap's error text (message, tips, possible values, usage) as one line:
/// the message with its tips and possible values in parentheses.
fn one_line(text: &str) -> String {
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let message = lines.next().unwrap_or("bad command line");
    let message = message.strip_prefix("error: ").unwrap_or(message);
    // Tips, possible values, and the arguments clap says are missing.
    let hints: Vec<&str> = lines
        .take_while(|l| !l.starts_with("Usage:"))
        .filter_map(|l| {
            l.strip_prefix("tip: ")
                .or_else(|| l.strip_prefix('[').and_then(|l| l.strip_suffix(']')))
                .or_else(|| l.starts_with('-').then_some(l))
        })
        .collect();
    if hints.is_empty() {
        format!("{message} (see --help)")
    } else {
        format!("{message} ({}; see --help)", hints.join("; "))
    }
}

/// A clap parser for a library [`Choice`]: its values are the choice's
/// spellings, so help texts and errors list them.
pub fn choice<T: Choice + Send + Sync>() -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(T::ALL.iter().map(|v| v.name()))
        .try_map(|name| T::from_name(&name).ok_or_else(|| format!("unknown value '{name}'")))
}

/// A time as the log lines and captions show it, to three significant
/// digits: `0.412 ms`, `12.3 ms`, `1.23 s`, `123 s`.
pub fn duration(seconds: f64) -> String {
    let (value, unit) = if seconds < 1.0 {
        (seconds * 1e3, "ms")
    } else {
        (seconds, "s")
    };
    let decimals = match value {
        v if v < 1.0 => 3,
        v if v < 10.0 => 2,
        v if v < 100.0 => 1,
        _ => 0,
    };
    format!("{value:.decimals$} {unit}")
}

/// The scene argument shared by `render` and `parity`.
#[derive(clap::Args, Debug, Clone)]
pub struct SceneInput {
    /// Scene file (.dae); the project's default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Largest scene file read, in MiB (larger files are refused before
    /// they are read).
    #[arg(long, value_name = "MIB", default_value_t = collada::DEFAULT_MAX_BYTES >> 20)]
    pub max_scene_mb: u64,
}

impl SceneInput {
    /// Loads the scene, or the built-in default scene when none was given.
    /// Its warnings go to stderr, one `hybrid: warning:` line each.
    pub fn load(&self, normals: NormalMode) -> Result<Scene, String> {
        let scene = match &self.scene {
            Some(p) => collada::load_limited(p, normals, self.max_scene_mb.saturating_mul(1 << 20))
                .map_err(|e| missing_scene_hint(p, e)),
            None => builtin::CORNELL.load(normals).map_err(|e| e.to_string()),
        }?;
        for warning in &scene.warnings {
            report_line("warning", warning);
        }
        Ok(scene)
    }
}

/// A scene that is not there: the error, and where the course's shared
/// scenes are (and the file itself, if `path` names one of them).
fn missing_scene_hint(path: &Path, e: collada::LoadError) -> String {
    let missing = matches!(&e, collada::LoadError::Io { source, .. }
        if source.kind() == std::io::ErrorKind::NotFound);
    if !missing || path.is_absolute() {
        return e.to_string();
    }
    let shared = shared_scenes_dir();
    let shared = shared.canonicalize().unwrap_or(shared);
    let there = shared.join(path);
    if there.is_file() {
        format!("{e}; the shared scenes hold {}", there.display())
    } else {
        format!(
            "{e}; the course's shared scenes are in {} (set HYBRID_SCENES to move it), e.g. {}",
            shared.display(),
            shared.join("sky/CBbunny.dae").display()
        )
    }
}

/// Where shared scenes are: `HYBRID_SCENES`, else `../shared/scenes`
/// beside the project.
pub fn shared_scenes_dir() -> PathBuf {
    match std::env::var_os("HYBRID_SCENES") {
        Some(d) => PathBuf::from(d),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes"),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn durations_keep_three_significant_digits() {
        let cases = [
            (0.000412, "0.412 ms"),
            (0.0123, "12.3 ms"),
            (0.123, "123 ms"),
            (1.234, "1.23 s"),
            (12.34, "12.3 s"),
            (123.4, "123 s"),
        ];
        for (seconds, shown) in cases {
            assert_eq!(super::duration(seconds), shown, "{seconds} s");
        }
    }
}
