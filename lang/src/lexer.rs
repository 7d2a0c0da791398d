//! Tokens, with Go's automatic semicolons.
//!
//! logos cuts the text into raw tokens; [`lex`] then applies Go's rule: a
//! newline (or a block comment spanning lines, or the end of the file) right
//! after an identifier, a literal, `)`, `]`, `}`, `++`, `--` or one of the
//! keywords `break continue fallthrough return` becomes a `;`. That is why
//! a condition split over lines must break after `&&` or `,`, exactly as in
//! Go, and why the mission files stay valid Go for `gofmt` and editors.
//!
//! Lexical problems (a stray character, an unterminated string or comment, a
//! malformed number) become diagnostics while lexing goes on, so the parser
//! still sees a plausible token stream and the run reports every problem.

use std::fmt;

use logos::Logos;

use crate::diag::Diagnostic;
use crate::span::Span;

/// A token as the parser sees it.
#[derive(Debug, Clone, PartialEq)]
pub enum Tok {
    Package,
    Const,
    Var,
    Func,
    /// A Go keyword the mission language does not use (`if`, `for`, ...):
    /// lexed as a keyword so the error can say so.
    Keyword(&'static str),
    Ident(String),
    Number(NumLit),
    Str(String),
    LParen,
    RParen,
    LBrace,
    RBrace,
    LBracket,
    RBracket,
    Comma,
    /// `;`, written or inserted (`auto`) at a newline or the end of the file.
    Semi {
        auto: bool,
    },
    Dot,
    Assign,
    OrOr,
    AndAnd,
    Not,
    EqEq,
    NotEq,
    Lt,
    Le,
    Gt,
    Ge,
    Plus,
    Minus,
    Star,
    Slash,
    /// A Go operator the mission language does not use (`:=`, `%`, `++`...).
    Op(&'static str),
}

/// A number literal. A malformed literal still becomes a token (marked
/// `bad`) so that the parser goes on; its diagnostic is already reported.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NumLit {
    pub value: f64,
    pub bad: bool,
}

impl fmt::Display for Tok {
    /// How an error message names the token (`unexpected newline`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tok::Package => f.write_str("keyword `package`"),
            Tok::Const => f.write_str("keyword `const`"),
            Tok::Var => f.write_str("keyword `var`"),
            Tok::Func => f.write_str("keyword `func`"),
            Tok::Keyword(k) => write!(f, "keyword `{k}`"),
            Tok::Ident(name) => write!(f, "name `{name}`"),
            Tok::Number(_) => f.write_str("number"),
            Tok::Str(_) => f.write_str("string"),
            Tok::Semi { auto: true } => f.write_str("newline"),
            other => write!(f, "`{}`", other.text()),
        }
    }
}

impl Tok {
    /// The source form of a punctuation token.
    pub fn text(&self) -> &'static str {
        match self {
            Tok::LParen => "(",
            Tok::RParen => ")",
            Tok::LBrace => "{",
            Tok::RBrace => "}",
            Tok::LBracket => "[",
            Tok::RBracket => "]",
            Tok::Comma => ",",
            Tok::Semi { .. } => ";",
            Tok::Dot => ".",
            Tok::Assign => "=",
            Tok::OrOr => "||",
            Tok::AndAnd => "&&",
            Tok::Not => "!",
            Tok::EqEq => "==",
            Tok::NotEq => "!=",
            Tok::Lt => "<",
            Tok::Le => "<=",
            Tok::Gt => ">",
            Tok::Ge => ">=",
            Tok::Plus => "+",
            Tok::Minus => "-",
            Tok::Star => "*",
            Tok::Slash => "/",
            Tok::Op(op) => op,
            Tok::Package => "package",
            Tok::Const => "const",
            Tok::Var => "var",
            Tok::Func => "func",
            Tok::Keyword(k) => k,
            Tok::Ident(_) | Tok::Number(_) | Tok::Str(_) => "",
        }
    }

    /// Go's rule: does a newline after this token end the statement?
    fn ends_statement(&self) -> bool {
        matches!(
            self,
            Tok::Ident(_)
                | Tok::Number(_)
                | Tok::Str(_)
                | Tok::RParen
                | Tok::RBracket
                | Tok::RBrace
                | Tok::Keyword("break" | "continue" | "fallthrough" | "return")
                | Tok::Op("++" | "--")
        )
    }
}

/// A token with its byte range, as lalrpop takes it.
pub type Spanned = (usize, Tok, usize);

/// The tokens of a file and the lexical problems found on the way.
#[derive(Debug, Clone, Default)]
pub struct Lexed {
    pub tokens: Vec<Spanned>,
    pub diagnostics: Vec<Diagnostic>,
}

/// Go operators outside the mission language, kept whole for messages.
const GO_OPERATORS: &[&str] = &[
    ":=", ":", "%", "&", "|", "^", "<<", ">>", "&^", "++", "--", "+=", "-=", "*=", "/=", "<-",
    "...",
];

const GO_KEYWORDS: &[&str] = &[
    "break",
    "case",
    "chan",
    "continue",
    "default",
    "defer",
    "else",
    "fallthrough",
    "for",
    "go",
    "goto",
    "if",
    "import",
    "interface",
    "map",
    "range",
    "return",
    "select",
    "struct",
    "switch",
    "type",
];

/// What a raw token callback found wrong; the token is still produced.
#[derive(Debug, Clone, PartialEq)]
struct Problem {
    code: &'static str,
    message: String,
    help: Option<String>,
}

#[derive(Debug, Clone, PartialEq)]
struct Scanned<T> {
    value: T,
    problem: Option<Problem>,
}

#[derive(Debug, Clone, PartialEq)]
struct Comment {
    newline: bool,
    terminated: bool,
}

#[derive(Logos, Debug, Clone, PartialEq)]
#[logos(skip r"[ \t\r\f]+")]
#[logos(skip r"//[^\n]*")]
enum Raw {
    #[token("\n")]
    Newline,
    #[token("/*", block_comment)]
    BlockComment(Comment),
    #[regex(r"[\p{L}_][\p{L}\p{Nd}_]*")]
    Ident,
    #[regex(r"[0-9]", number)]
    #[regex(r"\.[0-9]", number)]
    Number(Scanned<f64>),
    #[token("\"", interpreted_string)]
    #[token("`", raw_string)]
    Str(Scanned<String>),
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token("[")]
    LBracket,
    #[token("]")]
    RBracket,
    #[token(",")]
    Comma,
    #[token(";")]
    Semi,
    #[token(".")]
    Dot,
    #[token("=")]
    Assign,
    #[token("||")]
    OrOr,
    #[token("&&")]
    AndAnd,
    #[token("!")]
    Not,
    #[token("==")]
    EqEq,
    #[token("!=")]
    NotEq,
    #[token("<")]
    Lt,
    #[token("<=")]
    Le,
    #[token(">")]
    Gt,
    #[token(">=")]
    Ge,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    #[token(":=")]
    #[token(":")]
    #[token("%")]
    #[token("&")]
    #[token("|")]
    #[token("^")]
    #[token("<<")]
    #[token(">>")]
    #[token("&^")]
    #[token("++")]
    #[token("--")]
    #[token("+=")]
    #[token("-=")]
    #[token("*=")]
    #[token("/=")]
    #[token("<-")]
    #[token("...")]
    Op,
}

fn block_comment(lex: &mut logos::Lexer<Raw>) -> Comment {
    let rest = lex.remainder();
    match rest.find("*/") {
        Some(i) => {
            lex.bump(i + 2);
            Comment {
                newline: rest[..i].contains('\n'),
                terminated: true,
            }
        }
        None => {
            lex.bump(rest.len());
            Comment {
                newline: rest.contains('\n'),
                terminated: false,
            }
        }
    }
}

fn interpreted_string(lex: &mut logos::Lexer<Raw>) -> Scanned<String> {
    let rest = lex.remainder();
    let mut value = String::new();
    let mut problem = None;
    let mut chars = rest.char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        match c {
            '"' => {
                lex.bump(i + 1);
                return Scanned { value, problem };
            }
            '\n' => break,
            '\\' => {
                let Some(&(_, e)) = chars.peek() else { break };
                if e == '\n' {
                    break;
                }
                chars.next();
                let simple = match e {
                    'n' => Some('\n'),
                    't' => Some('\t'),
                    'r' => Some('\r'),
                    'a' => Some('\u{7}'),
                    'b' => Some('\u{8}'),
                    'f' => Some('\u{c}'),
                    'v' => Some('\u{b}'),
                    '\\' => Some('\\'),
                    '"' => Some('"'),
                    _ => None,
                };
                if let Some(s) = simple {
                    value.push(s);
                    continue;
                }
                let (digits, radix) = match e {
                    'x' => (2, 16),
                    'u' => (4, 16),
                    'U' => (8, 16),
                    '0'..='7' => (2, 8),
                    _ => (0, 0),
                };
                let mut code: u32 = if radix == 8 { e as u32 - '0' as u32 } else { 0 };
                let mut ok = radix != 0;
                for _ in 0..digits {
                    match chars.peek().and_then(|&(_, d)| d.to_digit(radix.max(2))) {
                        Some(d) if ok => {
                            code = code.saturating_mul(radix).saturating_add(d);
                            chars.next();
                        }
                        _ => ok = false,
                    }
                }
                match char::from_u32(code).filter(|_| ok) {
                    Some(ch) => value.push(ch),
                    None if problem.is_none() => {
                        problem = Some(Problem {
                            code: "eamos::bad-escape",
                            message: format!("unknown escape sequence `\\{e}` in a string"),
                            help: Some(
                                "event names are plain words; write a backslash as `\\\\`".into(),
                            ),
                        })
                    }
                    None => {}
                }
            }
            _ => value.push(c),
        }
    }
    let end = rest.find('\n').unwrap_or(rest.len());
    lex.bump(end);
    Scanned {
        value,
        problem: Some(Problem {
            code: "eamos::unterminated-string",
            message: "string not terminated".into(),
            help: Some("close it with `\"` on the same line".into()),
        }),
    }
}

fn raw_string(lex: &mut logos::Lexer<Raw>) -> Scanned<String> {
    let rest = lex.remainder();
    match rest.find('`') {
        Some(i) => {
            lex.bump(i + 1);
            Scanned {
                value: rest[..i].replace('\r', ""),
                problem: None,
            }
        }
        None => {
            lex.bump(rest.len());
            Scanned {
                value: rest.to_string(),
                problem: Some(Problem {
                    code: "eamos::unterminated-string",
                    message: "raw string not terminated".into(),
                    help: Some("close it with a backquote".into()),
                }),
            }
        }
    }
}

fn number(lex: &mut logos::Lexer<Raw>) -> Scanned<f64> {
    let start = lex.span().start;
    let text = &lex.source()[start..];
    let (len, result) = scan_number(text);
    let already = lex.slice().len();
    lex.bump(len.saturating_sub(already));
    match result {
        Ok(value) => Scanned {
            value,
            problem: None,
        },
        Err(message) => Scanned {
            value: 0.0,
            problem: Some(Problem {
                code: "eamos::bad-number",
                message,
                help: Some(
                    "numbers are written as in Go: `2`, `1.5`, `-0.2`, `1e3`, `0x1F`".into(),
                ),
            }),
        },
    }
}

/// Reads one Go number literal at the start of `text` (which starts with a
/// digit or `.digit`), the way Go's scanner does, and returns its length and
/// value. Letters and digits glued to the literal are swallowed into it so a
/// typo like `1.5m` is one error, not two.
pub fn scan_number(text: &str) -> (usize, Result<f64, String>) {
    let b = text.as_bytes();
    let mut i = 0;
    let mut base = 10u32;
    let mut prefix = ' ';
    if b.len() > 1 && b[0] == b'0' {
        match b[1].to_ascii_lowercase() {
            b'x' => (base, prefix) = (16, 'x'),
            b'o' => (base, prefix) = (8, 'o'),
            b'b' => (base, prefix) = (2, 'b'),
            _ => {}
        }
        if prefix != ' ' {
            i = 2;
        }
    }
    let digits_in = |b: &[u8], mut i: usize, hex: bool| {
        while i < b.len()
            && (b[i].is_ascii_digit() || b[i] == b'_' || (hex && b[i].is_ascii_hexdigit()))
        {
            i += 1;
        }
        i
    };
    let int_start = i;
    i = digits_in(b, i, base == 16);
    let int_part = &text[int_start..i];
    let mut frac_part = "";
    let mut has_dot = false;
    if i < b.len() && b[i] == b'.' {
        has_dot = true;
        let s = i + 1;
        i = digits_in(b, s, base == 16);
        frac_part = &text[s..i];
    }
    let mut exp_part = None;
    if i < b.len() && matches!(b[i].to_ascii_lowercase(), b'e' | b'p') {
        let marker = b[i].to_ascii_lowercase();
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        let s = j;
        j = digits_in(b, j, false);
        exp_part = Some((marker, &text[i + 1..j], s == j));
        i = j;
    }
    // Swallow letters, digits and dots glued to the literal.
    let mut glued = i;
    while glued < b.len()
        && (b[glued].is_ascii_alphanumeric() || b[glued] == b'_' || b[glued] == b'.')
    {
        glued += 1;
    }
    let literal = &text[..glued];
    if glued > i {
        return (
            glued,
            Err(format!(
                "malformed number `{literal}`: unexpected `{}`",
                &text[i..glued]
            )),
        );
    }
    let err = |m: String| (glued, Err(m));
    let check_underscores = |s: &str| -> bool {
        let bs = s.as_bytes();
        bs.iter().enumerate().all(|(k, &c)| {
            c != b'_'
                || (k + 1 < bs.len()
                    && bs[k + 1] != b'_'
                    && (k > 0 || prefix != ' ')
                    && (k == 0 || bs[k - 1] != b'_'))
        })
    };
    if !check_underscores(int_part)
        || frac_part.contains('_')
        || exp_part.is_some_and(|(_, e, _)| e.contains('_'))
    {
        return err(format!(
            "malformed number `{literal}`: `_` must separate successive digits"
        ));
    }
    let int_digits: String = int_part.chars().filter(|&c| c != '_').collect();
    let frac_digits = frac_part;
    let is_float = has_dot || exp_part.is_some();
    match base {
        16 => {
            if int_digits.is_empty() && frac_digits.is_empty() {
                return err(format!("hexadecimal literal `{literal}` has no digits"));
            }
            if let Some((m, _, no_digits)) = exp_part {
                if m != b'p' {
                    return err(format!("malformed number `{literal}`"));
                }
                if no_digits {
                    return err(format!("exponent of `{literal}` has no digits"));
                }
            } else if has_dot {
                return err(format!(
                    "hexadecimal mantissa of `{literal}` requires a `p` exponent"
                ));
            }
            let mut value = 0f64;
            for c in int_digits.chars().chain(frac_digits.chars()) {
                value = value * 16.0 + c.to_digit(16).unwrap_or(0) as f64;
            }
            value /= 16f64.powi(frac_digits.len() as i32);
            if let Some((_, e, _)) = exp_part {
                let e: i32 = e.parse().unwrap_or(if e.starts_with('-') {
                    i32::MIN / 2
                } else {
                    i32::MAX / 2
                });
                value *= 2f64.powi(e);
            }
            (glued, Ok(value))
        }
        8 | 2 if prefix != ' ' => {
            let name = if base == 8 { "octal" } else { "binary" };
            if is_float {
                return err(format!(
                    "invalid radix point or exponent in {name} literal `{literal}`"
                ));
            }
            if int_digits.is_empty() {
                return err(format!("{name} literal `{literal}` has no digits"));
            }
            digits_value(&int_digits, base, name, literal, glued)
        }
        _ => {
            if let Some((m, _, no_digits)) = exp_part {
                if m == b'p' {
                    return err(format!(
                        "malformed number `{literal}`: a `p` exponent requires a hexadecimal mantissa"
                    ));
                }
                if no_digits {
                    return err(format!("exponent of `{literal}` has no digits"));
                }
            }
            if !is_float && int_digits.len() > 1 && int_digits.starts_with('0') {
                // Go's legacy octal form, `0755`.
                return digits_value(&int_digits, 8, "octal", literal, glued);
            }
            let cleaned: String = literal.chars().filter(|&c| c != '_').collect();
            match cleaned.parse::<f64>() {
                Ok(v) if v.is_finite() => (glued, Ok(v)),
                Ok(_) => err(format!("number `{literal}` is too large")),
                Err(_) => err(format!("malformed number `{literal}`")),
            }
        }
    }
}

fn digits_value(
    digits: &str,
    base: u32,
    name: &str,
    literal: &str,
    len: usize,
) -> (usize, Result<f64, String>) {
    let mut value = 0f64;
    for c in digits.chars() {
        match c.to_digit(base) {
            Some(d) => value = value * base as f64 + d as f64,
            None => {
                return (
                    len,
                    Err(format!("invalid digit `{c}` in {name} literal `{literal}`")),
                )
            }
        }
    }
    (len, Ok(value))
}

/// Cuts a file into tokens, inserting Go's automatic semicolons.
pub fn lex(text: &str) -> Lexed {
    let mut out = Lexed::default();
    let mut raw = Raw::lexer(text);
    let mut last_ends_statement = false;
    let semi = |out: &mut Lexed, at: usize, last: &mut bool| {
        if *last {
            out.tokens.push((at, Tok::Semi { auto: true }, at));
        }
        *last = false;
    };
    while let Some(result) = raw.next() {
        let range = raw.span();
        let span = Span::new(range.start, range.end);
        let token = match result {
            Ok(Raw::Newline) => {
                semi(&mut out, range.start, &mut last_ends_statement);
                continue;
            }
            Ok(Raw::BlockComment(c)) => {
                if !c.terminated {
                    out.diagnostics.push(
                        Diagnostic::error(
                            "eamos::unterminated-comment",
                            Span::new(range.start, range.start + 2),
                            "comment not terminated",
                        )
                        .with_label("this comment is never closed")
                        .with_help("close it with `*/`"),
                    );
                }
                if c.newline || !c.terminated {
                    semi(&mut out, range.start, &mut last_ends_statement);
                }
                continue;
            }
            Ok(Raw::Ident) => {
                let word = raw.slice();
                match word {
                    "package" => Tok::Package,
                    "const" => Tok::Const,
                    "var" => Tok::Var,
                    "func" => Tok::Func,
                    w => match GO_KEYWORDS.iter().find(|k| **k == w) {
                        Some(k) => Tok::Keyword(k),
                        None => Tok::Ident(w.to_string()),
                    },
                }
            }
            Ok(Raw::Number(s)) => {
                let bad = s.problem.is_some();
                report(&mut out, span, s.problem);
                Tok::Number(NumLit {
                    value: s.value,
                    bad,
                })
            }
            Ok(Raw::Str(s)) => {
                report(&mut out, span, s.problem);
                Tok::Str(s.value)
            }
            Ok(Raw::LParen) => Tok::LParen,
            Ok(Raw::RParen) => Tok::RParen,
            Ok(Raw::LBrace) => Tok::LBrace,
            Ok(Raw::RBrace) => Tok::RBrace,
            Ok(Raw::LBracket) => Tok::LBracket,
            Ok(Raw::RBracket) => Tok::RBracket,
            Ok(Raw::Comma) => Tok::Comma,
            Ok(Raw::Semi) => Tok::Semi { auto: false },
            Ok(Raw::Dot) => Tok::Dot,
            Ok(Raw::Assign) => Tok::Assign,
            Ok(Raw::OrOr) => Tok::OrOr,
            Ok(Raw::AndAnd) => Tok::AndAnd,
            Ok(Raw::Not) => Tok::Not,
            Ok(Raw::EqEq) => Tok::EqEq,
            Ok(Raw::NotEq) => Tok::NotEq,
            Ok(Raw::Lt) => Tok::Lt,
            Ok(Raw::Le) => Tok::Le,
            Ok(Raw::Gt) => Tok::Gt,
            Ok(Raw::Ge) => Tok::Ge,
            Ok(Raw::Plus) => Tok::Plus,
            Ok(Raw::Minus) => Tok::Minus,
            Ok(Raw::Star) => Tok::Star,
            Ok(Raw::Slash) => Tok::Slash,
            Ok(Raw::Op) => {
                let text = raw.slice();
                Tok::Op(
                    GO_OPERATORS
                        .iter()
                        .find(|o| **o == text)
                        .copied()
                        .unwrap_or("?"),
                )
            }
            Err(()) => {
                out.diagnostics.push(stray(text, range.start, range.end));
                continue;
            }
        };
        last_ends_statement = token.ends_statement();
        out.tokens.push((range.start, token, range.end));
    }
    semi(&mut out, text.len(), &mut last_ends_statement);
    out
}

fn report(out: &mut Lexed, span: Span, problem: Option<Problem>) {
    if let Some(p) = problem {
        let mut d = Diagnostic::error(p.code, span, p.message).with_label("");
        d.help = p.help;
        out.diagnostics.push(d);
    }
}

fn stray(text: &str, start: usize, end: usize) -> Diagnostic {
    let c = text[start..].chars().next().unwrap_or('?');
    let end = end.max(start + c.len_utf8()).min(text.len());
    let shown = if c.is_control() || c.is_whitespace() {
        format!("U+{:04X}", c as u32)
    } else {
        format!("`{c}` (U+{:04X})", c as u32)
    };
    let help = match c {
        '\'' => Some("strings are written with double quotes: `Signal(\"name\")`".to_string()),
        '#' => Some("comments start with `//`".to_string()),
        _ => None,
    };
    let mut d = Diagnostic::error(
        "eamos::stray-character",
        Span::new(start, end),
        format!("unexpected character {shown}"),
    )
    .with_label("not part of the mission language");
    d.help = help;
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(src: &str) -> Vec<String> {
        lex(src)
            .tokens
            .into_iter()
            .map(|(_, t, _)| match t {
                Tok::Ident(n) => n,
                Tok::Number(n) => format!("{}", n.value),
                Tok::Str(s) => format!("{s:?}"),
                Tok::Semi { auto: true } => "⏎".into(),
                t => t.text().to_string(),
            })
            .collect()
    }

    #[test]
    fn a_newline_after_a_call_ends_the_statement() {
        assert_eq!(
            kinds("D.Arm()\nD.Land()"),
            ["D", ".", "Arm", "(", ")", "⏎", "D", ".", "Land", "(", ")", "⏎"]
        );
    }

    #[test]
    fn a_newline_after_an_operator_or_comma_does_not() {
        assert_eq!(kinds("a &&\nb,\nc"), ["a", "&&", "b", ",", "c", "⏎"]);
    }

    #[test]
    fn a_block_comment_spanning_lines_counts_as_a_newline() {
        assert_eq!(kinds("a /* x\n y */ b"), ["a", "⏎", "b", "⏎"]);
        assert_eq!(kinds("a /* x */ b"), ["a", "b", "⏎"]);
    }

    #[test]
    fn line_comments_are_skipped_but_their_newline_counts() {
        assert_eq!(kinds("a // c\nb"), ["a", "⏎", "b", "⏎"]);
    }

    #[test]
    fn numbers_take_every_go_form() {
        for (src, v) in [
            ("1", 1.0),
            ("1.5", 1.5),
            (".5", 0.5),
            ("1.", 1.0),
            ("1e3", 1000.0),
            ("2.5E-1", 0.25),
            ("0x1F", 31.0),
            ("0o17", 15.0),
            ("017", 15.0),
            ("0b101", 5.0),
            ("1_000", 1000.0),
            ("0x1p-2", 0.25),
            ("0x_1F", 31.0),
        ] {
            let (len, value) = scan_number(src);
            assert_eq!((len, value), (src.len(), Ok(v)), "{src}");
        }
    }

    #[test]
    fn malformed_numbers_are_errors_with_the_whole_literal() {
        for src in [
            "1.2.3", "0x", "1e", "1__0", "0b102", "089", "1.5m", "0x1.8", "1_",
        ] {
            let lexed = lex(src);
            assert_eq!(lexed.diagnostics.len(), 1, "{src}: {:?}", lexed.diagnostics);
            assert_eq!(lexed.diagnostics[0].code, "eamos::bad-number", "{src}");
        }
        assert_eq!(scan_number("1.2.3").0, 5, "the whole literal is one error");
    }

    #[test]
    fn strings_decode_escapes_and_report_unterminated_ones() {
        assert_eq!(kinds(r#""a\tb""#), [r#""a\tb""#, "⏎"]);
        assert_eq!(kinds("`raw\\n`"), [r#""raw\\n""#, "⏎"]);
        let lexed = lex("\"abc\nx");
        assert_eq!(lexed.diagnostics[0].code, "eamos::unterminated-string");
        assert_eq!(lexed.diagnostics[0].span, Span::new(0, 4));
        assert_eq!(lex(r#""\q""#).diagnostics[0].code, "eamos::bad-escape");
    }

    #[test]
    fn a_stray_character_is_reported_whole_and_skipped() {
        let lexed = lex("a é@€ b");
        let spans: Vec<_> = lexed.diagnostics.iter().map(|d| d.span).collect();
        assert_eq!(spans, [Span::new(4, 5), Span::new(5, 8)]);
        assert_eq!(kinds("a é@€ b"), ["a", "é", "b", "⏎"]);
    }

    #[test]
    fn go_keywords_outside_the_language_are_kept_as_keywords() {
        let toks: Vec<Tok> = lex("for return").tokens.into_iter().map(|t| t.1).collect();
        assert_eq!(
            toks,
            [
                Tok::Keyword("for"),
                Tok::Keyword("return"),
                Tok::Semi { auto: true }
            ]
        );
    }
}
