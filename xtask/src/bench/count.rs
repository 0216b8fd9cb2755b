//! Counting a bench firmware's instructions on QEMU: the run between the markers
//! `bench_start` and `bench_end`, the figures the firmware reports, and the count per function.

use super::{run, Result};
use object::{Object, ObjectSymbol};
use std::collections::HashMap;
use std::fs;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Command, Stdio};

/// One firmware variant's measurement.
#[derive(Debug, Clone, Default)]
pub(super) struct Run {
    pub(super) instructions: u64,
    pub(super) returns: u64,
    pub(super) lines: u64,
    pub(super) cells: u64,
    pub(super) stack: u64,
    pub(super) histogram: Vec<(String, u64)>,
    /// Instructions executed at each address (Thumb bit clear), for the per-line profile.
    pub(super) per_pc: Vec<(u32, u64)>,
    /// Instructions run inside the compiler's library routines, by the call site (the last
    /// instruction before the routine, Thumb bit clear) and the routine entered.
    pub(super) library_calls: Vec<(u32, String, u64)>,
}

impl Run {
    pub(super) fn per_return(&self) -> f64 {
        self.instructions as f64 / self.returns.max(1) as f64
    }
}

/// Function symbols of an ELF, sorted by address (Thumb bit cleared).
pub(super) fn functions(elf: &[u8]) -> Result<Vec<(u32, u32, String)>> {
    let file = object::File::parse(elf).map_err(|e| e.to_string())?;
    let mut f: Vec<(u32, u32, String)> = file
        .symbols()
        .filter(|s| s.kind() == object::SymbolKind::Text && s.size() > 0)
        .filter_map(|s| {
            let name = s.name().ok()?;
            let addr = u32::try_from(s.address()).ok()? & !1;
            Some((addr, u32::try_from(s.size()).ok()?, name.to_string()))
        })
        .collect();
    f.sort();
    Ok(f)
}

pub(super) fn symbol_address(elf: &[u8], name: &str) -> Result<(u32, u64)> {
    let file = object::File::parse(elf).map_err(|e| e.to_string())?;
    file.symbols()
        .find(|s| s.name() == Ok(name))
        .map(|s| (u32::try_from(s.address()).unwrap_or(0) & !1, s.size()))
        .ok_or_else(|| format!("no symbol {name} in the ELF"))
}

pub(super) fn short(name: &str) -> String {
    // Legacy-mangled Rust: keep the path's last two segments, readable enough.
    let d = name.strip_prefix("_ZN").map_or_else(
        || name.to_string(),
        |rest| {
            let mut parts = Vec::new();
            let mut s = rest;
            while let Some(end) = s.find(|c: char| !c.is_ascii_digit()) {
                let Ok(n) = s[..end].parse::<usize>() else {
                    break;
                };
                if end + n > s.len() {
                    break;
                }
                parts.push(s[end..end + n].to_string());
                s = &s[end + n..];
            }
            parts.retain(|p| !(p.starts_with('h') && p.len() == 17));
            let k = parts.len().saturating_sub(3);
            parts[k..]
                .join("::")
                .replace("$LT$", "<")
                .replace("$GT$", ">")
                .replace("$u20$", " ")
                .replace("..", "::")
        },
    );
    d.chars().take(90).collect()
}

/// Runs `elf` in QEMU with the exec trace streamed through a FIFO; counts the instructions
/// between the markers.
///
/// `singlestep`: QEMU translates one instruction per block (`-singlestep`), so each exec line
/// is one instruction. Otherwise (much faster) the blocks are logged as they are translated
/// (`-d in_asm`) with their instruction counts, and each exec line adds its block's count:
/// the same number as long as every block runs to its end, which holds here (no interrupt
/// or fault is enabled in the measured region; `cargo xtask bench --singlestep` checks it).
pub(super) fn trace(elf_path: &Path, fifo: &Path, singlestep: bool) -> Result<Run> {
    let elf = fs::read(elf_path).map_err(|e| format!("{}: {e}", elf_path.display()))?;
    let (start, _) = symbol_address(&elf, "bench_start")?;
    let (end, _) = symbol_address(&elf, "bench_end")?;
    let funcs = functions(&elf)?;
    // The compiler's library routines (64-bit multiply and divide, memcpy, …): their
    // instructions are also counted at the call site that entered them.
    let builtins: Vec<&(u32, u32, String)> = funcs
        .iter()
        .filter(|f| f.2.contains("compiler_builtins") || f.2.starts_with("__"))
        .collect();
    let builtin_at = |pc: u32| -> Option<usize> {
        let i = builtins.partition_point(|f| f.0 <= pc).checked_sub(1)?;
        builtins.get(i).filter(|f| pc < f.0 + f.1).map(|_| i)
    };
    // The last instruction run outside the routines (the call), and the routine it entered.
    let mut call_site = 0_u32;
    let mut entered: Option<usize> = None;
    let mut calls: HashMap<(u32, usize), u64> = HashMap::new();
    let _ = fs::remove_file(fifo);
    run(Command::new("mkfifo").arg(fifo))?;
    let mut qemu = Command::new("qemu-system-arm")
        .args([
            "-machine",
            "mps2-an386",
            "-cpu",
            "cortex-m4",
            "-nographic",
            "-monitor",
            "none",
            "-semihosting-config",
            "enable=on,target=native",
        ])
        .args(if singlestep {
            &["-singlestep"][..]
        } else {
            &[][..]
        })
        .args([
            "-d",
            if singlestep {
                "exec,nochain"
            } else {
                "in_asm,exec,nochain"
            },
            "-D",
        ])
        .arg(fifo)
        .arg("-kernel")
        .arg(elf_path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let reader = fs::File::open(fifo).map_err(|e| format!("{}: {e}", fifo.display()))?;
    let mut reader = BufReader::with_capacity(1 << 20, reader);
    let mut line = Vec::with_capacity(256);
    let mut counting = false;
    let mut done = false;
    let mut count = 0_u64;
    let mut pcs: HashMap<u32, u64> = HashMap::new();
    // Executions of each block (by its start address) in the measured region.
    let mut execs: HashMap<u32, u64> = HashMap::new();
    // Blocks as translated: start address → the addresses of their instructions.
    let mut block_pcs: HashMap<u32, Vec<u32>> = HashMap::new();
    let mut block: Option<(u32, Vec<u32>)> = None;
    loop {
        line.clear();
        match reader.read_until(b'\n', &mut line) {
            Ok(0) => break,
            Ok(_) => {}
            Err(e) => return Err(format!("reading the trace: {e}")),
        }
        if done {
            continue;
        }
        if !singlestep {
            // "0x00000404:  480e  ldr …" lines of an "IN:" listing.
            if line.starts_with(b"0x") {
                if let Some(pc) = std::str::from_utf8(&line[2..10])
                    .ok()
                    .and_then(|h| u32::from_str_radix(h, 16).ok())
                {
                    let b = block.get_or_insert((pc, Vec::new()));
                    b.1.push(pc);
                }
                continue;
            }
            if let Some((pc, addresses)) = block.take() {
                block_pcs.insert(pc, addresses);
            }
        }
        // "Trace 0: 0x7f… [00000000/0000abcd/…] symbol"
        let Some(open) = line.iter().position(|&b| b == b'[') else {
            continue;
        };
        let rest = &line[open + 1..];
        let Some(slash) = rest.iter().position(|&b| b == b'/') else {
            continue;
        };
        let hex = &rest[slash + 1..];
        let Some(len) = hex.iter().position(|&b| b == b'/' || b == b']') else {
            continue;
        };
        let Some(pc) = std::str::from_utf8(&hex[..len])
            .ok()
            .and_then(|h| u64::from_str_radix(h, 16).ok())
        else {
            continue;
        };
        let pc = pc as u32;
        if pc == start {
            counting = true;
            count = 0;
            pcs.clear();
            execs.clear();
        } else if pc == end && counting {
            counting = false;
            done = true;
        }
        if counting {
            let n = if singlestep {
                1
            } else {
                block_pcs
                    .get(&pc)
                    .map(|a| a.len() as u64)
                    .ok_or_else(|| format!("{pc:#010x} ran before its translation was logged"))?
            };
            count += n;
            *pcs.entry(pc).or_insert(0) += n;
            *execs.entry(pc).or_insert(0) += 1;
            match builtin_at(pc) {
                Some(routine) => {
                    let first = *entered.get_or_insert(routine);
                    *calls.entry((call_site, first)).or_insert(0) += n;
                }
                None => {
                    entered = None;
                    call_site = if singlestep {
                        pc
                    } else {
                        block_pcs
                            .get(&pc)
                            .and_then(|a| a.last())
                            .copied()
                            .unwrap_or(pc)
                    };
                }
            }
        }
    }
    let mut stdout = String::new();
    if let Some(mut s) = qemu.stdout.take() {
        let _ = s.read_to_string(&mut stdout);
    }
    let status = qemu.wait().map_err(|e| e.to_string())?;
    let _ = fs::remove_file(fifo);
    if !status.success() || !done {
        let mut stderr = String::new();
        if let Some(mut s) = qemu.stderr.take() {
            let _ = s.read_to_string(&mut stderr);
        }
        return Err(format!(
            "{}: QEMU {status}, markers {}found; stdout: {stdout} stderr: {stderr}",
            elf_path.display(),
            if done { "" } else { "not " }
        ));
    }
    let field = |key: &str| -> u64 {
        stdout
            .split_whitespace()
            .find_map(|w| w.strip_prefix(key)?.strip_prefix('=')?.parse().ok())
            .unwrap_or(0)
    };
    // The histogram by function.
    let mut by_fn: HashMap<String, u64> = HashMap::new();
    for (pc, n) in pcs {
        let i = funcs.partition_point(|f| f.0 <= pc);
        let name = i
            .checked_sub(1)
            .and_then(|i| funcs.get(i))
            .filter(|f| pc < f.0 + f.1)
            .map_or_else(|| format!("{pc:#010x}"), |f| short(&f.2));
        *by_fn.entry(name).or_insert(0) += n;
    }
    let mut histogram: Vec<(String, u64)> = by_fn.into_iter().collect();
    histogram.sort_by_key(|h| std::cmp::Reverse(h.1));
    // Every instruction of a block ran as often as the block (blocks run to their end here,
    // see above); with `-singlestep` a block is its one instruction.
    let mut per_instruction: HashMap<u32, u64> = HashMap::new();
    for (start, times) in execs {
        match block_pcs.get(&start) {
            Some(addresses) if !singlestep => {
                for &a in addresses {
                    *per_instruction.entry(a).or_insert(0) += times;
                }
            }
            _ => *per_instruction.entry(start).or_insert(0) += times,
        }
    }
    let mut per_pc: Vec<(u32, u64)> = per_instruction.into_iter().collect();
    per_pc.sort_unstable();
    let mut library_calls: Vec<(u32, String, u64)> = calls
        .into_iter()
        .filter_map(|((site, routine), n)| Some((site, short(&builtins.get(routine)?.2), n)))
        .collect();
    library_calls.sort_by(|a, b| b.2.cmp(&a.2).then_with(|| a.0.cmp(&b.0)));
    Ok(Run {
        instructions: count,
        returns: field("returns"),
        lines: field("lines"),
        cells: field("cells"),
        stack: field("stack"),
        histogram,
        per_pc,
        library_calls,
    })
}
