"""XML read safely, every element with its place: the BML and SSML that ``sgt import`` and
``sgt serve`` read (:mod:`dsl.bml`, :mod:`dsl.ssml`).

defusedxml's expat reader refuses a document type declaration (so no entity, internal or
external, is ever defined: no XXE, no billion laughs) and any external reference; nothing
outside the text is read. Elements nest at most :data:`MAX_DEPTH` deep. Every problem is one
:class:`XmlError` with the line and column (1-based) where the parser stopped.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from xml.sax import SAXParseException
from xml.sax.handler import ContentHandler, feature_namespaces
from xml.sax.xmlreader import InputSource

from defusedxml import DTDForbidden, EntitiesForbidden, ExternalReferenceForbidden
from defusedxml.expatreader import create_parser

#: The deepest nesting of elements a document may have (BML needs 4, SSML a handful).
MAX_DEPTH = 64


@dataclass
class Element:
    """One element: its local ``tag`` and namespace ``ns`` ("" for none), attributes by local
    name (a namespaced one as ``{ns}name``), where its start tag is, and its children: elements
    and text, in document order."""

    tag: str
    ns: str
    attrs: dict[str, str]
    line: int
    col: int
    children: list = field(default_factory=list)  # Element | str

    def elements(self) -> list[Element]:
        return [c for c in self.children if isinstance(c, Element)]

    def text(self) -> str:
        """All the text inside, tags left out."""
        return "".join(c if isinstance(c, str) else c.text() for c in self.children)


class XmlError(ValueError):
    """XML that is not read: ``message`` says why and what to do, at ``line``:``col``."""

    def __init__(self, message: str, line: int = 1, col: int = 1) -> None:
        super().__init__(message)
        self.message, self.line, self.col = message, line, col


def parse_xml(data: bytes | str) -> Element:
    """The root element of ``data`` (UTF-8 bytes or text). Raises :class:`XmlError`."""
    if isinstance(data, str):
        data = data.encode("utf-8")
    handler = _Builder()
    parser = create_parser(forbid_dtd=True, forbid_entities=True, forbid_external=True)
    parser.setFeature(feature_namespaces, True)
    parser.setContentHandler(handler)
    source = InputSource()
    source.setByteStream(io.BytesIO(data))
    try:
        parser.parse(source)
    except DTDForbidden:
        raise XmlError("the XML declares a document type (<!DOCTYPE ...>): sgt reads no DTD and no entities "
                       "(they can read other files or grow without bound); remove the declaration", *handler.where()) from None
    except EntitiesForbidden as exc:
        raise XmlError(f"the XML declares the entity '{exc.name}': sgt reads no entities; write the text itself",
                       *handler.where()) from None
    except ExternalReferenceForbidden:
        raise XmlError("the XML refers to an external file: sgt reads nothing outside the text; remove the reference",
                       *handler.where()) from None
    except SAXParseException as exc:
        raise XmlError(f"not well-formed XML: {exc.getMessage()}", exc.getLineNumber() or 1,
                       (exc.getColumnNumber() or 0) + 1) from None
    except _TooDeep as exc:
        raise XmlError(f"elements nest more than {MAX_DEPTH} deep: BML and SSML need a few levels", *exc.args) from None
    if handler.root is None:  # (expat reports an empty document itself; kept for safety)
        raise XmlError("no XML element in the text")
    return handler.root


class _TooDeep(Exception):
    pass


class _Builder(ContentHandler):
    def __init__(self) -> None:
        super().__init__()
        self.root: Element | None = None
        self.stack: list[Element] = []
        self.locator = None

    def setDocumentLocator(self, locator) -> None:  # (SAX names it)
        self.locator = locator

    def where(self) -> tuple[int, int]:
        if self.locator is None:
            return 1, 1
        return self.locator.getLineNumber() or 1, (self.locator.getColumnNumber() or 0) + 1

    def startElementNS(self, name, _qname, attrs) -> None:  # (SAX names it)
        line, col = self.where()
        if len(self.stack) >= MAX_DEPTH:
            raise _TooDeep(line, col)
        ns, tag = name
        own = {(f"{{{a_ns}}}{a_name}" if a_ns else a_name): value for (a_ns, a_name), value in attrs.items()}
        element = Element(tag, ns or "", own, line, col)
        if self.stack:
            self.stack[-1].children.append(element)
        else:
            self.root = element
        self.stack.append(element)

    def endElementNS(self, _name, _qname) -> None:  # (SAX names it)
        self.stack.pop()

    def characters(self, content) -> None:
        if not self.stack:
            return
        children = self.stack[-1].children
        if children and isinstance(children[-1], str):
            children[-1] += content
        else:
            children.append(content)
