//! The per-source-line profile of a bench run: every instruction QEMU executed between the
//! markers, attributed through the firmware's DWARF line tables (the release profile keeps
//! `debug = true`) to the innermost inlined function and the source line it came from.
//!
//! The per-function histogram (`profile-*.txt`) names only out-of-line functions, and fat LTO
//! inlines almost the whole per-return path into `replay`; the inline frames of the debug
//! information split it again (the accumulator, the geometry, the binning, the classifier's
//! fold) without changing the code that is measured.

use std::collections::HashMap;
use std::path::Path;

type Result<T> = std::result::Result<T, String>;

/// How many source lines the profile lists (the rest are summed in one line).
const TOP_LINES: usize = 120;

/// `lines-<target>-<bin>.txt`: instructions per return by innermost (inlined) function and by
/// source line, from the executed instructions' addresses `per_pc`.
pub fn profile(elf: &Path, run: &super::Run, root: &Path) -> Result<String> {
    let (per_pc, returns) = (&run.per_pc, run.returns);
    let loader = addr2line::Loader::new(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let total: u64 = per_pc.iter().map(|p| p.1).sum();
    let mut by_function: HashMap<String, u64> = HashMap::new();
    let mut by_line: HashMap<(String, String), u64> = HashMap::new();
    let mut by_chain: HashMap<String, u64> = HashMap::new();
    for &(pc, n) in per_pc.iter() {
        let (function, line, chain) = attribute(&loader, pc, root);
        *by_function.entry(function.clone()).or_insert(0) += n;
        *by_line.entry((line, function)).or_insert(0) += n;
        *by_chain.entry(chain).or_insert(0) += n;
    }
    let per_return = |n: u64| n as f64 / returns.max(1) as f64;
    // Runs without returns (the window and decay benches) are counted whole.
    let unit = if returns > 0 { "/ret" } else { "/run" };
    let mut out = format!(
        "# {} instructions, {} returns ({:.1} per return), attributed by the DWARF line tables\n",
        total,
        returns,
        per_return(total)
    );
    out.push_str("\n## By innermost function of this repository (inlined code counted where it was written; the\n## standard library's helpers where the project called them)\n\n");
    for (name, n) in sorted(by_function) {
        out.push_str(&format!(
            "{:>11.2}{unit} {:>5.1}%  {name}\n",
            per_return(n),
            percent(n, total)
        ));
    }
    out.push_str("\n## By inline path (the innermost three frames, outermost first)\n\n");
    for (name, n) in sorted(by_chain).into_iter().take(TOP_LINES) {
        out.push_str(&format!(
            "{:>11.2}{unit} {:>5.1}%  {name}\n",
            per_return(n),
            percent(n, total)
        ));
    }
    out.push_str(
        "\n## The compiler's library routines by call site (their instructions, also counted above)\n\n",
    );
    for (site, routine, n) in run.library_calls.iter().take(TOP_LINES) {
        let (function, line, _) = attribute(&loader, *site, root);
        out.push_str(&format!(
            "{:>11.2}{unit} {:>5.1}%  {routine} from {line}  ({function})\n",
            per_return(*n),
            percent(*n, total)
        ));
    }
    out.push_str("\n## By source line\n\n");
    let lines = sorted(by_line);
    let mut rest = 0;
    for (i, ((line, function), n)) in lines.into_iter().enumerate() {
        if i < TOP_LINES {
            out.push_str(&format!(
                "{:>11.2}{unit} {:>5.1}%  {line}  ({function})\n",
                per_return(n),
                percent(n, total)
            ));
        } else {
            rest += n;
        }
    }
    if rest > 0 {
        out.push_str(&format!(
            "{:>11.2}{unit} {:>5.1}%  (every other line)\n",
            per_return(rest),
            percent(rest, total)
        ));
    }
    Ok(out)
}

fn percent(n: u64, total: u64) -> f64 {
    100.0 * n as f64 / total.max(1) as f64
}

fn sorted<K: Ord>(map: HashMap<K, u64>) -> Vec<(K, u64)> {
    let mut v: Vec<(K, u64)> = map.into_iter().collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    v
}

/// The innermost function at `pc` written in this repository (code inlined from the
/// standard library, `clamp` or `saturating_add`, counts where the project called it), its
/// source line there, and the inline path (the innermost three frames, outermost first, joined
/// by ` > `).
fn attribute(loader: &addr2line::Loader, pc: u32, root: &Path) -> (String, String, String) {
    let unknown = || {
        let symbol = loader
            .find_symbol(u64::from(pc))
            .map_or_else(|| format!("{pc:#010x}"), shorten);
        (symbol.clone(), format!("{pc:#010x}"), symbol)
    };
    let Ok(mut frames) = loader.find_frames(u64::from(pc)) else {
        return unknown();
    };
    // (function, file relative to the repository or the library, line), innermost first.
    let mut stack: Vec<(String, Option<String>, u32)> = Vec::new();
    while let Ok(Some(frame)) = frames.next() {
        let name = frame
            .function
            .as_ref()
            .and_then(|f| f.demangle().ok())
            .map_or_else(|| "?".to_string(), |n| shorten(&n));
        let (file, line) = frame.location.as_ref().map_or((None, 0), |l| {
            (l.file.map(|f| relative(f, root)), l.line.unwrap_or(0))
        });
        stack.push((name, file, line));
    }
    let ours = |f: &Option<String>| {
        f.as_deref().is_some_and(|f| {
            !f.starts_with('/') && !f.starts_with("core/") && !f.starts_with("alloc/")
        })
    };
    let Some((function, file, line)) = stack
        .iter()
        .find(|frame| ours(&frame.1))
        .or_else(|| stack.first())
        .cloned()
    else {
        return unknown();
    };
    let mut chain: Vec<String> = stack.iter().take(3).map(|frame| frame.0.clone()).collect();
    chain.reverse();
    let chain = chain.join(" > ");
    (
        function,
        format!("{}:{line}", file.unwrap_or_else(|| "?".into())),
        chain,
    )
}

/// A source path relative to the repository, or the standard library's own.
fn relative(file: &str, root: &Path) -> String {
    let root = root.to_string_lossy();
    if let Some(rest) = file.strip_prefix(&*root) {
        return rest.trim_start_matches('/').to_string();
    }
    if let Some(i) = file.find("/library/") {
        return file[i + "/library/".len()..].to_string();
    }
    if let Some(i) = file.find("/registry/src/") {
        return file[i..].splitn(4, '/').last().unwrap_or(file).to_string();
    }
    file.to_string()
}

/// A demangled path without its hash and generic arguments, its last three segments.
fn shorten(name: &str) -> String {
    let mut plain = String::new();
    let mut depth = 0_u32;
    for c in name.chars() {
        match c {
            '<' => depth += 1,
            '>' => depth = depth.saturating_sub(1),
            _ if depth == 0 => plain.push(c),
            _ => {}
        }
    }
    let plain = match plain.rfind("::h") {
        Some(i) if plain.len() - i == 19 => plain[..i].to_string(),
        _ => plain,
    };
    let parts: Vec<&str> = plain.split("::").filter(|p| !p.is_empty()).collect();
    parts[parts.len().saturating_sub(3)..].join("::")
}
