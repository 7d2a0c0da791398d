//! Byte offsets (what every span of the front end holds) to the protocol's
//! positions and back. The protocol counts columns in UTF-16 code units by
//! default, the front end in bytes: a mission with `é` or an emoji in a
//! comment would otherwise put every marker after it in the wrong column.

use eamos_lang::Span;
use lsp_types::{Position, Range};

/// Where each line starts, for one version of a document.
#[derive(Debug, Clone)]
pub struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    pub fn new(text: &str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    /// The position of a byte offset; an offset past the end or inside a
    /// character clamps to the character's start.
    pub fn position(&self, text: &str, offset: usize) -> Position {
        let offset = floor_char(text, offset.min(text.len()));
        let line = self.starts.partition_point(|&s| s <= offset) - 1;
        let start = self.starts[line];
        let character = text[start..offset].encode_utf16().count();
        Position::new(line as u32, character as u32)
    }

    /// The byte offset of a position; a column past the line's end clamps
    /// to its end, a line past the last to the end of the text.
    pub fn offset(&self, text: &str, pos: Position) -> usize {
        let Some(&start) = self.starts.get(pos.line as usize) else {
            return text.len();
        };
        let end = self
            .starts
            .get(pos.line as usize + 1)
            .map_or(text.len(), |&next| next - 1);
        let mut units = 0u32;
        for (i, c) in text[start..end].char_indices() {
            if units >= pos.character {
                return start + i;
            }
            units += c.len_utf16() as u32;
        }
        end
    }

    pub fn range(&self, text: &str, span: Span) -> Range {
        Range::new(
            self.position(text, span.start as usize),
            self.position(text, span.end as usize),
        )
    }

    pub fn span(&self, text: &str, range: Range) -> Span {
        Span::new(self.offset(text, range.start), self.offset(text, range.end))
    }
}

fn floor_char(text: &str, mut offset: usize) -> usize {
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_count_utf16_units() {
        // `é` is two bytes and one unit; `🚁` four bytes and two units.
        let text = "a\n\u{e9}\u{1F681}x\n";
        let ix = LineIndex::new(text);
        let x = text.find('x').unwrap();
        assert_eq!(ix.position(text, x), Position::new(1, 3));
        assert_eq!(ix.offset(text, Position::new(1, 3)), x);
        assert_eq!(ix.offset(text, Position::new(1, 1)), 4);
        let text = "\u{e9}\u{e9}\u{e9}x";
        let ix = LineIndex::new(text);
        assert_eq!(ix.offset(text, Position::new(0, 3)), 6);
        assert_eq!(ix.position(text, 6), Position::new(0, 3));
    }

    #[test]
    fn positions_out_of_range_clamp() {
        let text = "ab\ncd";
        let ix = LineIndex::new(text);
        assert_eq!(ix.offset(text, Position::new(0, 99)), 2);
        assert_eq!(ix.offset(text, Position::new(9, 0)), text.len());
        assert_eq!(ix.position(text, 99), Position::new(1, 2));
    }

    #[test]
    fn an_offset_inside_a_character_clamps_to_its_start() {
        let text = "\u{e9}";
        assert_eq!(LineIndex::new(text).position(text, 1), Position::new(0, 0));
    }
}
