//! A small, strict reader for the subset of XML the LWPR model files use: an optional XML
//! declaration, comments, elements with single- or double-quoted attributes, and character data
//! (whitespace-separated numbers). DTDs, CDATA sections and processing instructions other than
//! the declaration are refused. Nesting deeper than [`MAX_DEPTH`] is refused, so no input can
//! exhaust the stack; every error is a message with the byte offset where it was found.

/// Deepest element nesting accepted (the model files use four levels).
pub(super) const MAX_DEPTH: usize = 8;

/// One element: its name, attributes in file order, child elements and its own character data
/// (the text between its children, concatenated, separated by a space).
#[derive(Debug, Default)]
pub(super) struct Element {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub text: String,
}

impl Element {
    /// The value of attribute `key`, if present.
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

struct Cursor<'a> {
    s: &'a str,
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn rest(&self) -> &'a str {
        &self.s[self.pos..]
    }
    fn err<T>(&self, what: impl std::fmt::Display) -> Result<T, String> {
        Err(format!("XML error at byte {}: {what}", self.pos))
    }
    fn skip_ws(&mut self) {
        let r = self.rest();
        self.pos += r.len() - r.trim_start_matches([' ', '\t', '\r', '\n']).len();
    }
    fn eat(&mut self, p: &str) -> bool {
        if self.rest().starts_with(p) {
            self.pos += p.len();
            true
        } else {
            false
        }
    }
    /// Skips past the next `end`, or fails with `what` when it never comes.
    fn skip_past(&mut self, end: &str, what: &str) -> Result<(), String> {
        match self.rest().find(end) {
            Some(i) => {
                self.pos += i + end.len();
                Ok(())
            }
            None => self.err(format!("unterminated {what}")),
        }
    }
    fn name(&mut self) -> Result<String, String> {
        let r = self.rest();
        let len = r
            .find(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | ':')))
            .unwrap_or(r.len());
        if len == 0 || !r.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
            return self.err("expected a name");
        }
        self.pos += len;
        Ok(r[..len].to_string())
    }
    /// Comments and whitespace between markup.
    fn skip_misc(&mut self) -> Result<(), String> {
        loop {
            self.skip_ws();
            if self.eat("<!--") {
                self.skip_past("-->", "comment")?;
            } else {
                return Ok(());
            }
        }
    }
}

/// Replaces the five predefined entities; any other `&` is an error.
fn unescape(raw: &str) -> Result<String, String> {
    let mut out = String::with_capacity(raw.len());
    let mut rest = raw;
    while let Some(i) = rest.find('&') {
        out.push_str(&rest[..i]);
        rest = &rest[i..];
        let (rep, len) = [
            ("&lt;", '<'),
            ("&gt;", '>'),
            ("&amp;", '&'),
            ("&apos;", '\''),
            ("&quot;", '"'),
        ]
        .iter()
        .find(|(e, _)| rest.starts_with(e))
        .map(|(e, c)| (*c, e.len()))
        .ok_or_else(|| "unsupported entity or stray `&`".to_string())?;
        out.push(rep);
        rest = &rest[len..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Parses a whole document into its root element.
pub(super) fn parse(s: &str) -> Result<Element, String> {
    let mut c = Cursor {
        s: s.strip_prefix('\u{feff}').unwrap_or(s),
        pos: 0,
    };
    c.skip_ws();
    if c.eat("<?xml") {
        c.skip_past("?>", "XML declaration")?;
    }
    c.skip_misc()?;
    let mut stack: Vec<Element> = Vec::new();
    let mut root = None;
    loop {
        if stack.is_empty()
            && let Some(done) = root.take()
        {
            c.skip_misc()?;
            if !c.rest().is_empty() {
                return c.err("content after the root element");
            }
            return Ok(done);
        }
        if c.rest().is_empty() {
            return c.err(match stack.last() {
                Some(e) => format!("truncated document (element <{}> not closed)", e.name),
                None => "no root element".to_string(),
            });
        }
        if c.eat("<!--") {
            c.skip_past("-->", "comment")?;
        } else if c.rest().starts_with("<!") || c.rest().starts_with("<?") {
            return c.err("DTDs, CDATA and processing instructions are not supported");
        } else if c.eat("</") {
            let name = c.name()?;
            c.skip_ws();
            if !c.eat(">") {
                return c.err("expected `>`");
            }
            let Some(done) = stack.pop() else {
                return c.err(format!("unexpected closing tag </{name}>"));
            };
            if done.name != name {
                return c.err(format!("</{name}> closes <{}>", done.name));
            }
            match stack.last_mut() {
                Some(parent) => parent.children.push(done),
                None => root = Some(done),
            }
        } else if c.eat("<") {
            if stack.len() >= MAX_DEPTH {
                return c.err(format!("elements nested deeper than {MAX_DEPTH}"));
            }
            let mut e = Element {
                name: c.name()?,
                ..Element::default()
            };
            let closed = loop {
                let before = c.pos;
                c.skip_ws();
                if c.eat("/>") {
                    break true;
                }
                if c.eat(">") {
                    break false;
                }
                if c.pos == before {
                    return c.err("expected whitespace before an attribute");
                }
                let key = c.name()?;
                c.skip_ws();
                if !c.eat("=") {
                    return c.err(format!("attribute `{key}` without `=`"));
                }
                c.skip_ws();
                let quote = match c.rest().chars().next() {
                    Some(q @ ('\'' | '"')) => q,
                    _ => return c.err("attribute value must be quoted"),
                };
                c.pos += 1;
                let Some(end) = c.rest().find(quote) else {
                    return c.err("unterminated attribute value");
                };
                let raw = &c.rest()[..end];
                if raw.contains('<') {
                    return c.err("`<` in an attribute value");
                }
                let value = unescape(raw).or_else(|m| c.err(m))?;
                c.pos += end + 1;
                if e.attrs.iter().any(|(k, _)| *k == key) {
                    return c.err(format!("attribute `{key}` given twice"));
                }
                e.attrs.push((key, value));
            };
            if closed {
                match stack.last_mut() {
                    Some(parent) => parent.children.push(e),
                    None => root = Some(e),
                }
            } else {
                stack.push(e);
            }
        } else {
            let end = c.rest().find('<').unwrap_or(c.rest().len());
            let raw = &c.rest()[..end];
            let Some(e) = stack.last_mut() else {
                return c.err("text outside the root element");
            };
            let text = unescape(raw).or_else(|m| c.err(m))?;
            if !e.text.is_empty() {
                e.text.push(' ');
            }
            e.text.push_str(&text);
            c.pos += end;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_subset() {
        let e = parse(
            "<?xml version='1.0' encoding='US-ASCII' ?>\n<!-- c -->\n<a x='1' y=\"t&amp;u\">\n <b n='v'> 1 2\n 3 </b><c/>\n</a>\n",
        )
        .unwrap();
        assert_eq!(e.name, "a");
        assert_eq!(e.attr("y"), Some("t&u"));
        assert_eq!(e.children.len(), 2);
        assert_eq!(e.children[0].text.split_whitespace().count(), 3);
        assert_eq!(e.children[1].name, "c");
    }

    #[test]
    fn refuses_malformed_documents() {
        for bad in [
            "",
            "<a>",
            "<a></b>",
            "<a x=1></a>",
            "<a x='1' x='2'></a>",
            "<a></a><b></b>",
            "text<a></a>",
            "<a>&bogus;</a>",
            "<!DOCTYPE a><a></a>",
            "<a><![CDATA[x]]></a>",
            "<a x='1'y='2'></a>",
            "<a><!-- open </a>",
            "<a x='1></a>",
            "</a>",
        ] {
            assert!(parse(bad).is_err(), "{bad:?} was accepted");
        }
        let deep = "<a>".repeat(MAX_DEPTH + 1) + &"</a>".repeat(MAX_DEPTH + 1);
        assert!(parse(&deep).unwrap_err().contains("deeper"));
        let ok = "<a>".repeat(MAX_DEPTH) + &"</a>".repeat(MAX_DEPTH);
        assert!(parse(&ok).is_ok());
    }
}
