//! Tests of the disassembly parser and the analysis on small inputs.

use super::*;

#[test]
fn names_are_readable() {
    assert_eq!(
        clean_name("core::slice::_$LT$impl$u20$$u5b$T$u5d$$GT$::copy_within::h5eafefba35f37474"),
        "core::slice::<impl [T]>::copy_within"
    );
    assert_eq!(
        clean_name("firmware::task::EstimatorTask$LT$_$C$_$C$_$GT$::on_sample::h834e2d712183d710"),
        "firmware::task::EstimatorTask<_,_,_>::on_sample"
    );
    assert_eq!(
            clean_name("_$LT$core..iter..adapters..take..Take$LT$I$GT$$u20$as$u20$core..iter..traits..iterator..Iterator$GT$::nth::hcc674072ee447c86"),
            "<core::iter::adapters::take::Take<I> as core::iter::traits::iterator::Iterator>::nth"
        );
    assert_eq!(
        clean_name("<usize as core::fmt::Display>::fmt"),
        "<usize as core::fmt::Display>::fmt"
    );
    assert_eq!(clean_name("__aeabi_memcpy4"), "__aeabi_memcpy4");
}

#[test]
fn panic_entries() {
    for n in [
        "core::panicking::panic_bounds_check",
        "core::panicking::panic_fmt",
        "core::slice::index::slice_index_fail",
        "core::option::unwrap_failed",
        "core::result::unwrap_failed",
        "__rustc::rust_begin_unwind",
    ] {
        assert!(is_panic_entry(n), "{n}");
    }
    for n in [
        "core::slice::<impl [T]>::copy_within",
        "firmware::board::qemu::fail",
        "<usize as core::fmt::Display>::fmt",
    ] {
        assert!(!is_panic_entry(n), "{n}");
    }
}

fn one(line: &str) -> Insn {
    insn(line).expect("an instruction")
}

#[test]
fn branches() {
    let b = |l: &str| branch(&one(l));
    assert_eq!(
        b("     798:      \tbl\t0x1e71e <core::slice::index::slice_index_fail> @ imm = #0x1df82"),
        Some(Branch::Direct(0x1e71e))
    );
    assert_eq!(
            b("    2fb2:      \tbhs.w\t0x1e7b4 <core::panicking::panic_bounds_check+0x4> @ imm = #0x1b768"),
            Some(Branch::Direct(0x1e7b4))
        );
    assert_eq!(
        b("     a16:      \tble\t0xa20 <f+0x10> @ imm = #0x6"),
        Some(Branch::Direct(0xa20))
    );
    assert_eq!(b("   1e5ee:      \tblx\tr3"), Some(Branch::Indirect));
    assert_eq!(b("    ee1a:      \tbxne\tlr"), None);
    assert_eq!(b("     a1c:      \tbic\tr0, r0, #0x1"), None);
    assert_eq!(b("     a1c:      \tbkpt\t#0xab"), None);
    assert_eq!(b("     a1c:      \tbfc\tr6, #21, #11"), None);
    assert_eq!(b("   1e8ac: 58 02 55 02  \t.word\t0x02550258"), None);
}

#[test]
fn sites_and_reachability() {
    // A root calling `work`, which indexes; `other` (not reachable)
    // panics too; the location of `work`'s bounds check is in flash.
    let mut flash = vec![0u8; 0x40];
    let file = b"estimator-core/src/frac.rs";
    flash[0x20..0x20 + file.len()].copy_from_slice(file);
    for (k, v) in [0x1020u32, file.len() as u32, 99, 25].iter().enumerate() {
        flash[4 * k..4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    let image = Elf {
        sections: vec![(0x1000, &flash)],
    };
    let text = "\
00000100 <firmware::task::EstimatorTask$LT$_$C$_$C$_$GT$::on_sample::h834e2d712183d710>:
     100:      \tbl\t0x200 <work> @ imm = #0xfc
     104:      \tbx\tlr
00000200 <work>:
     200:      \tcmp\tr0, #0x40
     202:      \tbhs\t0x206 <work+0x6> @ imm = #0x0
     204:      \tbx\tlr
     206:      \tmovw\tr2, #0x1000
     20a:      \tmov.w\tr0, #0xffffffff
     20e:      \tmovt\tr2, #0x0
     212:      \tmovs\tr1, #0x40
     214:      \tbl\t0x400 <core::panicking::panic_bounds_check> @ imm = #0x1e8
00000300 <other>:
     300:      \tb.w\t0x402 <core::panicking::panic_bounds_check+0x2> @ imm = #0xfe
00000400 <core::panicking::panic_bounds_check>:
     400:      \tbl\t0x500 <__rustc::rust_begin_unwind> @ imm = #0xfc
00000500 <__rustc::rust_begin_unwind>:
     500:      \tb\t0x500 <__rustc::rust_begin_unwind> @ imm = #-0x4
";
    let funcs = parse_disassembly(text);
    assert_eq!(funcs.len(), 5);
    let r = analyse(&funcs, &image, &[DEFAULT_ROOT.to_owned()]).unwrap();
    assert_eq!(r.sites.len(), 2);
    let reached: Vec<&Site> = r.reachable_sites().collect();
    assert_eq!(reached.len(), 1);
    assert_eq!(reached[0].addr, 0x214);
    assert_eq!(reached[0].panic, "panic_bounds_check");
    assert_eq!(
        reached[0].location.as_deref(),
        Some("estimator-core/src/frac.rs:99:25")
    );
    assert_eq!(reached[0].args, [Some(u32::MAX), Some(0x40)]);
    assert!(r.indirect.is_empty() && r.traps.is_empty());
    assert!(analyse(&funcs, &image, &["no_such_fn".to_owned()]).is_err());
}

#[test]
fn a_shared_call_block_has_the_locations_of_its_paths() {
    // Two locations (0x1000: frac.rs:99, 0x1010: frac.rs:7) reach one
    // `bl` through a shared block: fall-through and a branch.
    let file = b"estimator-core/src/frac.rs";
    let mut flash = vec![0u8; 0x40];
    flash[0x20..0x20 + file.len()].copy_from_slice(file);
    for (at, line) in [(0usize, 99u32), (0x10, 7)] {
        for (k, v) in [0x1020u32, file.len() as u32, line, 5].iter().enumerate() {
            flash[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    let image = Elf {
        sections: vec![(0x1000, &flash)],
    };
    let text = "\
00000100 <on_sample>:
     100:      \tbx\tlr
     102:      \tmovw\tr3, #0x1000
     106:      \tmovt\tr3, #0x0
     10a:      \tmov\tr1, r4
     10c:      \tmov\tr2, lr
     10e:      \tbl\t0x400 <core::slice::index::slice_index_fail> @ imm = #0x2ee
     112:      \tmovw\tr3, #0x1010
     116:      \tmovt\tr3, #0x0
     11a:      \tb\t0x10a <on_sample+0xa> @ imm = #-0x14
00000400 <core::slice::index::slice_index_fail>:
     400:      \tb\t0x400 <core::slice::index::slice_index_fail> @ imm = #-0x4
";
    let funcs = parse_disassembly(text);
    let r = analyse(&funcs, &image, &["on_sample".to_owned()]).unwrap();
    assert_eq!(r.sites.len(), 1);
    assert_eq!(
        r.sites[0].location.as_deref(),
        Some("estimator-core/src/frac.rs:7:5 | estimator-core/src/frac.rs:99:5")
    );
}
