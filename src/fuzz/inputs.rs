//! Generated parser inputs: arbitrary byte strings, and structure-aware mutations of real files
//! (byte flips, truncations, lines duplicated, deleted or swapped, numbers replaced by extremes,
//! splices, BOMs and line-ending changes). Each input is a pure function of its random stream.

use rand::Rng;
use rand_pcg::Pcg64Mcg;

/// Numbers a real file never holds but a damaged or hostile one may: non-finite, signed zero,
/// the ends of f64 and of the integer types, absurd counts, near-numbers.
pub const EXTREME_NUMBERS: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "-0",
    "-0.0",
    "0",
    "1e308",
    "-1e308",
    "1e309",
    "1e-308",
    "5e-324",
    "1e12",
    "-1",
    "4294967296",
    "9223372036854775807",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999999999",
    "1000000000000",
    "0.30000000000000004",
    "1_000",
    "0x10",
    "1e",
    "-",
    ".",
    "1.2.3",
    "",
];

/// Characters the formats are made of, so random text gets past the first byte more often.
const ALPHABET: &[u8] = b"0123456789.,-+eE:=[]{}\"' \n\t_abcdnfrstxyz/\\#";

/// An arbitrary byte string: uniform bytes or text from the formats' alphabet, usually short,
/// sometimes a few kilobytes.
pub fn arbitrary(rng: &mut Pcg64Mcg) -> Vec<u8> {
    let len = if rng.gen_bool(0.9) {
        rng.gen_range(0..256)
    } else {
        rng.gen_range(0..4096)
    };
    let textual = rng.gen_bool(0.7);
    (0..len)
        .map(|_| {
            if textual {
                ALPHABET[rng.gen_range(0..ALPHABET.len())]
            } else {
                rng.gen()
            }
        })
        .collect()
}

/// One to four stacked mutations of `seed`; `other` is a second file to splice from.
pub fn mutate(rng: &mut Pcg64Mcg, seed: &[u8], other: &[u8]) -> Vec<u8> {
    let mut data = seed.to_vec();
    for _ in 0..rng.gen_range(1..=4) {
        data = mutate_once(rng, data, other);
    }
    data
}

fn mutate_once(rng: &mut Pcg64Mcg, mut data: Vec<u8>, other: &[u8]) -> Vec<u8> {
    match rng.gen_range(0..12) {
        0 => {
            if !data.is_empty() {
                let i = rng.gen_range(0..data.len());
                data[i] ^= 1 << rng.gen_range(0..8);
            }
            data
        }
        1 => {
            if !data.is_empty() {
                let i = rng.gen_range(0..data.len());
                data[i] = rng.gen();
            }
            data
        }
        2 => {
            let cut = rng.gen_range(0..=data.len());
            data.truncate(cut);
            data
        }
        3 => edit_lines(rng, &data, LineEdit::Delete),
        4 => edit_lines(rng, &data, LineEdit::Duplicate),
        5 => edit_lines(rng, &data, LineEdit::Swap),
        6 | 7 => replace_number(rng, &data),
        8 => {
            let at = rng.gen_range(0..=data.len());
            let chunk: Vec<u8> = (0..rng.gen_range(1..16)).map(|_| rng.gen()).collect();
            data.splice(at..at, chunk);
            data
        }
        9 => {
            if other.is_empty() {
                return data;
            }
            let a = rng.gen_range(0..other.len());
            let b = rng.gen_range(a..=other.len().min(a + 512));
            let at = rng.gen_range(0..=data.len());
            data.splice(at..at, other[a..b].iter().copied());
            data
        }
        10 => {
            let mut out = b"\xEF\xBB\xBF".to_vec();
            out.extend_from_slice(&data);
            out
        }
        _ => match rng.gen_range(0..3) {
            0 => replace_all(&data, b"\n", b"\r\n"),
            1 => replace_all(&data, b"\n", b"\r"),
            _ => {
                let at = rng.gen_range(0..=data.len());
                data.insert(at, 0);
                data
            }
        },
    }
}

enum LineEdit {
    Delete,
    Duplicate,
    Swap,
}

fn edit_lines(rng: &mut Pcg64Mcg, data: &[u8], edit: LineEdit) -> Vec<u8> {
    let mut lines: Vec<&[u8]> = data.split_inclusive(|&b| b == b'\n').collect();
    if lines.is_empty() {
        return data.to_vec();
    }
    let i = rng.gen_range(0..lines.len());
    match edit {
        LineEdit::Delete => {
            let n = rng.gen_range(1..=8).min(lines.len() - i);
            lines.drain(i..i + n);
        }
        LineEdit::Duplicate => {
            // Mostly a few copies; sometimes enough to make a count absurd for a small file.
            let copies = if rng.gen_bool(0.9) {
                rng.gen_range(1..4)
            } else {
                rng.gen_range(100..2000)
            };
            let line = lines[i];
            // At most ~1 MiB added: a long line copied thousands of times tests the reader's
            // memory, not the parser.
            let copies = copies.min((1 << 20) / line.len().max(1)).max(1);
            for _ in 0..copies {
                lines.insert(i, line);
            }
        }
        LineEdit::Swap => {
            let j = rng.gen_range(0..lines.len());
            lines.swap(i, j);
        }
    }
    lines.concat()
}

/// Byte ranges of the number-like tokens of `data` (digits with signs, points and exponents).
fn number_spans(data: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < data.len() {
        if data[i].is_ascii_digit() {
            let mut start = i;
            if start > 0 && (data[start - 1] == b'-' || data[start - 1] == b'+') {
                start -= 1;
            }
            while i < data.len() && matches!(data[i], b'0'..=b'9' | b'.' | b'e' | b'E' | b'_') {
                i += 1;
                if i < data.len() && matches!(data[i - 1], b'e' | b'E') && data[i] == b'-' {
                    i += 1;
                }
            }
            spans.push((start, i));
        } else {
            i += 1;
        }
    }
    spans
}

/// Replaces one number of `data` with an extreme (or a random integer of any size).
fn replace_number(rng: &mut Pcg64Mcg, data: &[u8]) -> Vec<u8> {
    let spans = number_spans(data);
    if spans.is_empty() {
        return data.to_vec();
    }
    let (a, b) = spans[rng.gen_range(0..spans.len())];
    let replacement = if rng.gen_bool(0.8) {
        EXTREME_NUMBERS[rng.gen_range(0..EXTREME_NUMBERS.len())].to_string()
    } else {
        rng.gen::<u64>().to_string()
    };
    let mut out = data[..a].to_vec();
    out.extend_from_slice(replacement.as_bytes());
    out.extend_from_slice(&data[b..]);
    out
}

fn replace_all(data: &[u8], from: &[u8], to: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() + data.len() / 16);
    let mut i = 0;
    while i < data.len() {
        if data[i..].starts_with(from) {
            out.extend_from_slice(to);
            i += from.len();
        } else {
            out.push(data[i]);
            i += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{stream, Stream};

    #[test]
    fn finds_numbers_with_signs_and_exponents() {
        let spans = number_spans(b"a = -1.5e-3, b: 42");
        assert_eq!(spans, vec![(4, 11), (16, 18)]);
    }

    #[test]
    fn mutations_are_a_function_of_the_stream() {
        let seed = b"frame,t_s\n0,0.0\n1,0.033\n";
        let a = mutate(&mut stream(1, Stream::Fuzz, 5), seed, b"x");
        let b = mutate(&mut stream(1, Stream::Fuzz, 5), seed, b"x");
        assert_eq!(a, b);
        let differ = (0..20).any(|i| mutate(&mut stream(1, Stream::Fuzz, i), seed, b"x") != a);
        assert!(differ);
    }

    #[test]
    fn extreme_numbers_replace_a_number() {
        // Over many streams every extreme shows up in place of the single number.
        let seen: std::collections::BTreeSet<Vec<u8>> = (0..2000)
            .map(|i| replace_number(&mut stream(2, Stream::Fuzz, i), b"x = 7\n"))
            .collect();
        assert!(seen.contains(b"x = NaN\n".as_slice()));
        assert!(seen.contains(b"x = 1e308\n".as_slice()));
        assert!(seen.contains(b"x = -0\n".as_slice()));
    }
}
