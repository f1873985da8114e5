//! The document reader's output as text, for comparing its shortcut and general paths.
//! Shared by the property tests and the `read_paths` fuzz target.

use x30_panel::proto::xml::{Items, StructureError, read_document, read_document_general};

/// Everything the reader hands out, with (`shortcuts`) or without its shortcuts: each
/// block's items (name and text), then the envelope and block count, or the error.
pub fn reader_trace(body: &[u8], shortcuts: bool) -> String {
    let text = |bytes: &[u8]| String::from_utf8_lossy(bytes).into_owned();
    let mut trace = String::new();
    let mut on_items = |envelope: &_, items: &mut Items<'_, '_>| {
        trace.push_str(&format!("block {envelope:?}:"));
        for item in items {
            let item = item.map_err(StructureError::Xml)?;
            trace.push_str(&format!(" {}={:?}", text(item.name), item.text.map(text)));
        }
        trace.push('\n');
        Ok::<_, StructureError>(())
    };
    let result = if shortcuts {
        read_document(body, &mut on_items)
    } else {
        read_document_general(body, &mut on_items)
    };
    format!("{trace}{result:?}")
}
