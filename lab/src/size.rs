//! `lab size`: flash, static RAM and stack of each board's firmware.
//!
//! Flash and RAM come from the ELF's section headers (parsed here, no tool needed): flash =
//! `.vector_table + .text + .rodata + .data`, RAM = `.data + .bss + .uninit`. The stack is
//! the high-water mark the firmware measures by stack painting: for `qemu-mps2` after a real
//! run (the 3DTK recording through `pyramid run --board qemu`, as the demo runs it);
//! `stm32f4` needs its board (`null`). With `--json` the one JSON object is all that goes to
//! stdout; progress goes to stderr.
use crate::demo::{record_3dtk, run_args, shared_data, FLAGS_3DTK};
use serde::Serialize;
use std::path::Path;
use std::process::ExitCode;
use terrain_pyramid_host::emulator::{build_firmware, qemu_available, BOARD_DIR, INSTALL_HINT};
use terrain_pyramid_host::run::{self, Board};

/// Arguments of `lab size`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize, Debug)]
struct BoardSize {
    name: &'static str,
    flash_bytes: u64,
    ram_bytes: u64,
    stack_bytes: Option<u64>,
}

#[derive(Serialize, Debug)]
struct Sizes {
    boards: Vec<BoardSize>,
}

/// Flash and static RAM of an ELF32 little-endian image, bytes.
///
/// # Errors
/// Not an ELF32 LE file.
pub fn elf_sizes(data: &[u8]) -> Result<(u64, u64), String> {
    let u16_at = |o: usize| data.get(o..o + 2).map(|b| u16::from_le_bytes([b[0], b[1]]));
    let u32_at = |o: usize| {
        data.get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    if data.get(..6) != Some(&[0x7F, b'E', b'L', b'F', 1, 1][..]) {
        return Err("not a 32-bit little-endian ELF".into());
    }
    let bad = || "truncated ELF".to_string();
    let shoff = u32_at(0x20).ok_or_else(bad)? as usize;
    let shentsize = usize::from(u16_at(0x2E).ok_or_else(bad)?);
    let shnum = usize::from(u16_at(0x30).ok_or_else(bad)?);
    let shstrndx = usize::from(u16_at(0x32).ok_or_else(bad)?);
    let section = |i: usize| -> Option<(u32, u32)> {
        let at = shoff + i * shentsize;
        Some((u32_at(at)?, u32_at(at + 0x14)?))
    };
    let strtab = shoff + shstrndx * shentsize;
    let str_off = u32_at(strtab + 0x10).ok_or_else(bad)? as usize;
    let (mut flash, mut ram) = (0_u64, 0_u64);
    for i in 0..shnum {
        let (name_off, size) = section(i).ok_or_else(bad)?;
        let start = str_off + name_off as usize;
        let name = data
            .get(start..)
            .and_then(|s| s.split(|&b| b == 0).next())
            .unwrap_or(&[]);
        let size = u64::from(size);
        match name {
            b".vector_table" | b".text" | b".rodata" => flash += size,
            b".data" => {
                flash += size;
                ram += size;
            }
            b".bss" | b".uninit" => ram += size,
            _ => {}
        }
    }
    Ok((flash, ram))
}

fn sizes_of(elf: &Path) -> Result<(u64, u64), String> {
    let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    elf_sizes(&data)
}

/// The qemu-mps2 firmware's stack after the 3DTK recording (or `None` without the data).
fn qemu_stack() -> Result<Option<u64>, String> {
    let scan = shared_data().join("3dtk-tilt-scan").join("scan000.3d");
    if !scan.is_file() {
        eprintln!("note: {} is absent: no stack measurement", scan.display());
        return Ok(None);
    }
    let dir = std::env::temp_dir().join(format!("lab-size-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let rec = dir.join("scan000.rec");
    let run = record_3dtk(&rec)
        .and_then(|()| run_args(Board::Qemu, &rec, &dir.join("maps"), FLAGS_3DTK))
        .and_then(|args| run::execute(&args).map_err(|(_, message)| message));
    let _ = std::fs::remove_dir_all(&dir);
    let summary: serde_json::Value = serde_json::from_str(&run?).map_err(|e| e.to_string())?;
    Ok(summary["stack_bytes"].as_u64())
}

fn measure() -> Result<Sizes, String> {
    let qemu_dir = Path::new(BOARD_DIR);
    let qemu_elf = build_firmware(qemu_dir, "qemu-mps2")?;
    let (flash, ram) = sizes_of(&qemu_elf)?;
    let stack = if qemu_available() {
        qemu_stack()?
    } else {
        eprintln!("note: {INSTALL_HINT}");
        None
    };
    let mut boards = vec![BoardSize {
        name: "qemu-mps2",
        flash_bytes: flash,
        ram_bytes: ram,
        stack_bytes: stack,
    }];
    let stm_dir = qemu_dir.join("../stm32f4");
    let stm_elf = build_firmware(&stm_dir, "stm32f4-board")?;
    let (flash, ram) = sizes_of(&stm_elf)?;
    boards.push(BoardSize {
        name: "stm32f4",
        flash_bytes: flash,
        ram_bytes: ram,
        stack_bytes: None,
    });
    Ok(Sizes { boards })
}

/// Runs `lab size`.
pub fn run(args: &Args) -> ExitCode {
    match measure() {
        Ok(sizes) => {
            if args.json {
                match serde_json::to_string(&sizes) {
                    Ok(json) => println!("{json}"),
                    Err(e) => {
                        eprintln!("error: {e}");
                        return ExitCode::FAILURE;
                    }
                }
            } else {
                println!(
                    "{:<12} {:>10} {:>14} {:>18}",
                    "board", "flash (B)", "static RAM (B)", "stack high-water"
                );
                for b in &sizes.boards {
                    let stack = b
                        .stack_bytes
                        .map_or("on the board".into(), |s| s.to_string());
                    println!(
                        "{:<12} {:>10} {:>14} {:>18}",
                        b.name, b.flash_bytes, b.ram_bytes, stack
                    );
                }
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
