//! What the checked mission holds: constants folded, parameters substituted,
//! every call its own instance, conditions with Go's precedence, the entry
//! point found, and the limits that keep a mission finite.

use eamos_lang::hir::{self, BinaryOp, BlockKind, CondMode, DroneId, Expr, Stmt, UnaryOp};
use eamos_lang::{compile, parser, Compiled, Diagnostic, SourceFile};

fn build(text: &str) -> Result<Compiled, Vec<Diagnostic>> {
    compile(&SourceFile::new("m.go", text), &eamos_profile::builtin())
}

fn ok(text: &str) -> hir::Mission {
    match build(text) {
        Ok(c) => c.mission,
        Err(d) => panic!("{d:#?}"),
    }
}

fn codes(text: &str) -> Vec<&'static str> {
    match build(text) {
        Ok(c) => c.warnings.iter().map(|d| d.code).collect(),
        Err(d) => d.iter().map(|d| d.code).collect(),
    }
}

fn actions(m: &hir::Mission) -> Vec<(u16, String, Vec<f64>)> {
    let mut out = Vec::new();
    m.root.walk(&mut |s| {
        if let Stmt::Action(a) = s {
            out.push((a.drone.0, a.name.clone(), a.args.clone()));
        }
    });
    out
}

#[test]
fn constants_are_folded_through_other_constants() {
    let m = ok("package M\nconst Side = 2.5\nconst (\n\tHalf = Side / 2\n\tNeg = -Half * (1 + 1)\n)\n\
                var D Quadcopter\nfunc INIT() {\n\tD.FlyByX(Half)\n\tD.FlyByY(Neg)\n\tD.FlyTo(1e1, 0x10, .5)\n}\n");
    assert_eq!(
        actions(&m),
        [
            (0, "FlyByX".into(), vec![1.25]),
            (0, "FlyByY".into(), vec![-2.5]),
            (0, "FlyTo".into(), vec![10.0, 16.0, 0.5])
        ]
    );
}

#[test]
fn parameters_are_substituted_at_every_call() {
    let m = ok("package M\nvar (\n\tA Quadcopter\n\tB Quadcopter\n)\n\
                func INIT() {\n\tSEQ_Square(A, 2)\n\tSEQ_Square(B, 3)\n}\n\
                func SEQ_Square(d Quadcopter, side float64) {\n\td.FlyByX(side)\n\td.FlyByY(-side)\n}\n");
    assert_eq!(
        actions(&m),
        [
            (0, "FlyByX".into(), vec![2.0]),
            (0, "FlyByY".into(), vec![-2.0]),
            (1, "FlyByX".into(), vec![3.0]),
            (1, "FlyByY".into(), vec![-3.0])
        ]
    );
}

#[test]
fn parameters_pass_on_through_nested_calls_and_into_conditions() {
    let m = ok("package M\nvar A, B Quadcopter\nfunc INIT() {\n\tSEQ_Outer(B, 4)\n}\n\
                func SEQ_Outer(d Quadcopter, n int) {\n\tSEQ_Inner(d, n * 2)\n}\n\
                func SEQ_Inner(x Quadcopter, k float64) {\n\tRepeatFor(k, SEQ_Lap)\n\tx.Hover(k)\n\t\
                PauseUntil(x.DistanceTo(A) < k)\n}\nfunc SEQ_Lap() {\n\tA.FlyByX(1)\n}\n");
    let mut seen = Vec::new();
    m.root.walk(&mut |s| match s {
        Stmt::RepeatFor { count, .. } => seen.push(format!("repeat {count}")),
        Stmt::Action(a) => seen.push(format!("{} {} {:?}", a.drone.0, a.name, a.args)),
        Stmt::Pause {
            cond: Expr::Binary { lhs, rhs, .. },
            ..
        } => {
            if let (Expr::Property { drone, args, .. }, Expr::Number { value, .. }) =
                (&**lhs, &**rhs)
            {
                seen.push(format!("pause {} {:?} {value}", drone.0, args));
            }
        }
        _ => {}
    });
    assert_eq!(
        seen,
        [
            "repeat 8",
            "0 FlyByX [1.0]",
            "1 Hover [8.0]",
            "pause 1 [DroneId(0)] 8"
        ]
    );
}

#[test]
fn every_call_of_a_block_is_its_own_instance() {
    let m = ok("package M\nvar D Quadcopter\nfunc INIT() {\n\tPAR_X()\n\tPAR_X()\n\tRepeatFor(2, PAR_X)\n}\n\
                func PAR_X() {\n\tD.TakePhoto()\n}\n");
    let mut blocks = Vec::new();
    m.root
        .walk_blocks(&mut |b| blocks.push((b.name.clone(), b.kind, b.span)));
    assert_eq!(blocks.len(), 4);
    assert_eq!(blocks[0].1, BlockKind::Seq, "INIT runs in sequence");
    assert!(blocks[1..]
        .iter()
        .all(|b| b.0 == "PAR_X" && b.1 == BlockKind::Par));
    let spans: std::collections::HashSet<_> = blocks[1..].iter().map(|b| b.2).collect();
    assert_eq!(
        spans.len(),
        3,
        "each instance keeps the span of its own call"
    );
}

#[test]
fn the_eleven_control_structures_lower_to_their_hir_forms() {
    let m = ok("package M\nvar D Quadcopter\nfunc INIT() {\n\
        \tIf(D.IsArmed(), SEQ_B)\n\tIf(!D.IsArmed(), SEQ_B, SEQ_B)\n\
        \tWaitWhile(D.Z() < 1, SEQ_B)\n\tWaitUntil(D.Z() > 1, SEQ_B)\n\
        \tRepeatWhile(D.X() < 5, SEQ_B)\n\tRepeatUntil(D.X() >= 5, SEQ_B, SEQ_B)\n\
        \tRepeatFor(3, SEQ_B)\n\tPauseWhile(D.Battery() < 10)\n\tPauseUntil(D.Battery() >= 90)\n\
        \tPauseFor(2.5)\n\tDoWhile(D.Battery() > 20, SEQ_B)\n\tDoUntil(D.Battery() <= 20, SEQ_B)\n}\n\
        func SEQ_B() {\n\tD.FlyByX(1)\n}\n");
    let s = m.summary();
    let kinds: Vec<&str> = s.controls.keys().map(String::as_str).collect();
    assert_eq!(
        kinds,
        [
            "DoUntil",
            "DoWhile",
            "If",
            "PauseFor",
            "PauseUntil",
            "PauseWhile",
            "RepeatFor",
            "RepeatUntil",
            "RepeatWhile",
            "WaitUntil",
            "WaitWhile"
        ]
    );
    assert_eq!(s.controls["If"], 2);
    let mut modes = Vec::new();
    m.root.walk(&mut |st| match st {
        Stmt::Repeat { mode, exit, .. } => modes.push((*mode, exit.is_some())),
        Stmt::PauseFor { seconds, .. } => assert_eq!(*seconds, 2.5),
        _ => {}
    });
    assert_eq!(modes, [(CondMode::While, false), (CondMode::Until, true)]);
}

#[test]
fn conditions_follow_gos_precedence() {
    // `||` < `&&` < comparisons < `+ -` < `* /` < unary.
    let e = parser::parse_expr("a || b && c < d + e * -f").expect("parses");
    use eamos_lang::ast::ExprKind as K;
    let K::Binary {
        op: BinaryOp::Or,
        rhs,
        ..
    } = &e.kind
    else {
        panic!("{e:?}")
    };
    let K::Binary {
        op: BinaryOp::And,
        rhs,
        ..
    } = &rhs.kind
    else {
        panic!("{rhs:?}")
    };
    let K::Binary {
        op: BinaryOp::Lt,
        rhs,
        ..
    } = &rhs.kind
    else {
        panic!("{rhs:?}")
    };
    let K::Binary {
        op: BinaryOp::Add,
        rhs,
        ..
    } = &rhs.kind
    else {
        panic!("{rhs:?}")
    };
    let K::Binary {
        op: BinaryOp::Mul,
        rhs,
        ..
    } = &rhs.kind
    else {
        panic!("{rhs:?}")
    };
    assert!(matches!(
        rhs.kind,
        K::Unary {
            op: UnaryOp::Neg,
            ..
        }
    ));
    let e = parser::parse_expr("(a || b) && c").expect("parses");
    assert!(matches!(
        e.kind,
        K::Binary {
            op: BinaryOp::And,
            ..
        }
    ));
}

#[test]
fn constant_parts_of_a_condition_are_folded_and_property_reads_kept() {
    let m = ok(
        "package M\nconst Edge = 30\nvar D Quadcopter\nfunc INIT() {\n\
                \tWaitUntil(D.X() > -Edge+10 && true, SEQ_B)\n}\nfunc SEQ_B() {\n\tD.Land()\n}\n",
    );
    let mut cond = None;
    m.root.walk(&mut |s| {
        if let Stmt::Wait { cond: c, .. } = s {
            cond = Some(c.clone());
        }
    });
    let Some(Expr::Binary {
        op: BinaryOp::And,
        lhs,
        rhs,
        ..
    }) = cond
    else {
        panic!()
    };
    assert!(matches!(*rhs, Expr::Bool { value: true, .. }));
    let Expr::Binary {
        op: BinaryOp::Gt,
        lhs,
        rhs,
        ..
    } = *lhs
    else {
        panic!()
    };
    assert!(matches!(*lhs, Expr::Property { drone: DroneId(0), ref name, .. } if name == "X"));
    assert!(matches!(*rhs, Expr::Number { value, .. } if value == -20.0));
}

#[test]
fn without_init_the_entry_is_the_one_function_nobody_calls() {
    let m = ok("package M\nvar D Quadcopter\nfunc SEQ_Helper() {\n\tD.Land()\n}\nfunc SEQ_Main() {\n\tSEQ_Helper()\n}\n");
    assert_eq!(m.entry, "SEQ_Main");
    assert_eq!(m.root.name, "SEQ_Main");
}

#[test]
fn a_par_entry_point_runs_its_statements_in_parallel() {
    let m = ok("package M\nvar D Quadcopter\nfunc PAR_Main() {\n\tD.Land()\n\tD.TakePhoto()\n}\n");
    assert_eq!(m.root.kind, BlockKind::Par);
}

#[test]
fn signals_and_awaits_name_their_events() {
    let m = ok(
        "package M\nvar A, B Quadcopter\nfunc PAR_Main() {\n\tSEQ_A()\n\tSEQ_B()\n}\n\
                func SEQ_A() {\n\tA.Takeoff(1)\n\tSignal(\"up\")\n}\n\
                func SEQ_B() {\n\tAwait(\"up\")\n\tB.Takeoff(1)\n}\n",
    );
    assert_eq!(m.summary().events, ["up"]);
}

#[test]
fn a_signal_in_the_exit_of_a_loop_is_fine_but_not_in_its_body() {
    let exit = "package M\nvar D Quadcopter\nfunc INIT() {\n\tRepeatWhile(D.X() < 3, SEQ_B, SEQ_E)\n\tAwait(\"done\")\n}\n\
                func SEQ_B() {\n\tD.FlyByX(1)\n}\nfunc SEQ_E() {\n\tSignal(\"done\")\n}\n";
    assert!(build(exit).is_ok());
    let body = exit.replace("SEQ_B, SEQ_E", "SEQ_E, SEQ_B");
    assert_eq!(codes(&body), ["eamos::signal-in-loop"]);
}

#[test]
fn a_mission_whose_calls_double_at_every_level_is_refused_not_expanded_forever() {
    let mut text = String::from("package M\nvar D Quadcopter\nfunc INIT() {\n\tSEQ_0()\n}\n");
    for i in 0..30 {
        text.push_str(&format!(
            "func SEQ_{i}() {{\n\tSEQ_{n}()\n\tSEQ_{n}()\n}}\n",
            n = i + 1
        ));
    }
    text.push_str("func SEQ_30() {\n\tD.TakePhoto()\n}\n");
    assert_eq!(codes(&text), ["eamos::mission-too-large"]);
}

#[test]
fn an_empty_mission_compiles_with_a_warning() {
    let c = build("package M\nfunc INIT() {}\n").expect("compiles");
    assert_eq!(
        c.warnings.iter().map(|d| d.code).collect::<Vec<_>>(),
        ["eamos::empty-mission"]
    );
}

#[test]
fn an_empty_file_is_missing_its_package_and_its_entry() {
    assert_eq!(codes(""), ["eamos::missing-package", "eamos::no-entry"]);
}

#[test]
fn go_formatting_variants_parse_as_go_parses_them() {
    // Trailing commas, explicit semicolons, block comments with newlines,
    // grouped declarations, typed constants, unary plus.
    let m = ok("package M /* the\nname */\nconst N int = 2; const F float64 = +1.5\nvar (\n\tD Quadcopter;\n)\n\
                func INIT() { D.FlyTo(\n\t1,\n\tF,\n\tN,\n); D.Land() }\n");
    assert_eq!(
        actions(&m),
        [
            (0, "FlyTo".into(), vec![1.0, 1.5, 2.0]),
            (0, "Land".into(), vec![])
        ]
    );
}

#[test]
fn diagnostics_come_in_source_order_with_stable_codes() {
    let Err(d) = build(
        "package M\nvar D Quadcopter\nfunc INIT() {\n\tD.Fly(1)\n\tX.Land()\n\tD.Takeoff()\n}\n",
    ) else {
        panic!("compiles")
    };
    let codes: Vec<_> = d.iter().map(|d| d.code).collect();
    assert_eq!(
        codes,
        [
            "eamos::unknown-action",
            "eamos::unknown-drone",
            "eamos::arg-count"
        ]
    );
    assert!(d.windows(2).all(|w| w[0].span.start <= w[1].span.start));
}

#[test]
fn checks_use_the_profiles_handed_in_not_a_built_in_list() {
    let mut table = eamos_profile::ProfileTable::new();
    table
        .insert(
            eamos_profile::ProfileTable::parse_profile(
                "name = \"Rover\"\n[actions.Drive]\nparams = [{ name = \"d\", kind = \"metres\" }]\n",
            )
            .unwrap(),
        )
        .unwrap();
    let file = SourceFile::new(
        "r.go",
        "package R\nvar R1 Rover\nfunc INIT() {\n\tR1.Drive(3)\n}\n",
    );
    assert!(compile(&file, &table).is_ok());
    let file = SourceFile::new(
        "q.go",
        "package Q\nvar Q1 Quadcopter\nfunc INIT() {\n\tQ1.Land()\n}\n",
    );
    let Err(d) = compile(&file, &table) else {
        panic!("Quadcopter is not in this table")
    };
    assert_eq!(d[0].code, "eamos::unknown-profile");
}

#[test]
fn block_calls_nested_too_deep_are_refused_not_overflowing_the_stack() {
    let mut text = String::from("package M\nvar D Quadcopter\nfunc INIT() {\n\tSEQ_0()\n}\n");
    for i in 0..5000 {
        text.push_str(&format!("func SEQ_{i}() {{\n\tSEQ_{}()\n}}\n", i + 1));
    }
    text.push_str("func SEQ_5000() {\n\tD.TakePhoto()\n}\n");
    assert_eq!(codes(&text), ["eamos::mission-too-large"]);
}

#[test]
fn expressions_nested_or_chained_beyond_reason_are_refused_not_overflowing_the_stack() {
    for expr in [
        format!("{}1{}", "(".repeat(100_000), ")".repeat(100_000)),
        format!("1{}", "+1".repeat(100_000)),
        format!("{}1", "- ".repeat(100_000)),
    ] {
        let text = format!("package M\nvar D Quadcopter\nfunc INIT() {{\n\tD.FlyByX({expr})\n}}\n");
        assert_eq!(codes(&text), ["eamos::too-complex"]);
    }
}
