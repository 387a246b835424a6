"""The ccsds-ndm library behind one door: loaded only when a CCSDS file is read or written, refused in one line
(with the install command) when it is not installed."""

import os
from pathlib import Path

from liaison_cli.errors import ExchangeFileError

INSTALL_HINT = "pip install 'liaison[ccsds]' (or: pip install ccsds-ndm)"
FORMATS = ("kvn", "xml")


def _ndm_io():
    try:
        from ccsds_ndm.ndm_io import NdmIo
    except ImportError:
        raise ExchangeFileError(f"CCSDS files need the ccsds-ndm library, which is not installed: {INSTALL_HINT}") \
            from None
    return NdmIo()


# The largest CCSDS file read (a 60-day OEM every 60 s is ~10 MB of KVN; a TDM of 100 days of three links every
# 10 s ~100 MB): a device or a runaway file (/dev/zero) is refused instead of filling the memory (issue 35).
MAX_MESSAGE_BYTES = 512 * 2**20


def read_message(path, kind: str):
    """The message object of a CCSDS file (KVN or XML, detected), checked to be an `kind` ('OEM', 'OPM',
    'TDM'). A file that cannot be read or parsed raises ExchangeFileError naming it."""
    path = Path(path)
    io = _ndm_io()
    try:
        with open(path, "rb") as handle:
            # A regular file's size is known before reading: refused without reading it (a device or a pipe is
            # read up to the cap, which the length check below catches).
            size = os.fstat(handle.fileno()).st_size
            data = handle.read(MAX_MESSAGE_BYTES + 1) if size <= MAX_MESSAGE_BYTES else b""
        if size > MAX_MESSAGE_BYTES or len(data) > MAX_MESSAGE_BYTES:
            raise ExchangeFileError(f"{path}: larger than {MAX_MESSAGE_BYTES // 2**20} MiB; allowed: a CCSDS {kind} "
                                    "file of at most that size")
        text = data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ExchangeFileError(f"{path}: cannot read the {kind}: {getattr(exc, 'strerror', None) or exc}") from None
    try:
        message = io.from_string(text)
    except Exception as exc:  # noqa: BLE001 - the library raises many types for a malformed file
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ExchangeFileError(f"{path}: malformed CCSDS message ({detail[:200]})") from None
    found = type(message).__name__.upper()
    if not found.startswith(kind):
        raise ExchangeFileError(f"{path}: is a {found.removesuffix('TYPE')}, expected a CCSDS {kind}")
    return message


# Where a validator finds the schema of the XML written: SANA's unqualified NDM/XML 4.0.0 master schema (OEM 3.0,
# OPM 3.0 and TDM 2.0 are its messages; ccsds-ndm's models are generated from it).
XSI_NAMESPACE = "http://www.w3.org/2001/XMLSchema-instance"
NDM_XML_SCHEMA = "https://sanaregistry.org/r/ndmxml_unqualified/ndmxml-4.0.0-master-4.0.xsd"


def message_text(message, data_format: str) -> str:
    """The message as KVN or XML text; the XML's root element names its schema (xsi:noNamespaceSchemaLocation)."""
    from ccsds_ndm.mapping import NDMFileFormats

    io = _ndm_io()
    if data_format not in FORMATS:
        raise ExchangeFileError(f"format {data_format!r}: allowed {', '.join(FORMATS)}")
    text = io.to_string(message, NDMFileFormats.KVN if data_format == "kvn" else NDMFileFormats.XML)
    return text if data_format == "kvn" else with_schema_location(text)


def with_schema_location(xml_text: str) -> str:
    """The XML with xmlns:xsi and xsi:noNamespaceSchemaLocation on its root element (unchanged if it has them)."""
    import re

    root = re.search(r"<(?![?!])([A-Za-z_][\w.-]*)", xml_text)
    if root is None or "noNamespaceSchemaLocation" in xml_text[root.start():xml_text.index(">", root.start())]:
        return xml_text
    insert = f' xmlns:xsi="{XSI_NAMESPACE}" xsi:noNamespaceSchemaLocation="{NDM_XML_SCHEMA}"'
    return xml_text[:root.end()] + insert + xml_text[root.end():]


def models():
    """The ccsds-ndm dataclasses of the NDM/XML 4.0 schema (OEM 3.0, OPM 3.0, TDM 2.0) as two modules."""
    _ndm_io()
    from ccsds_ndm.models.ndmxml4 import ndmxml_4_0_0_common_4_0 as common
    from ccsds_ndm.models.ndmxml4 import ndmxml_4_0_0_master_4_0 as master

    return common, master
