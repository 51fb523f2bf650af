"""SUMO's XML inputs, plain or gzipped (``.net.xml.gz``, ``.rou.xml.gz``), as SUMO reads them.

SUMO and sumolib read a gzipped net or route file as they read a plain one; so must every other
reader of the same file. :func:`sumolib.openz` opens either.
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import sumolib


def xml_root(path: str | Path) -> ET.Element:
    """The root element of the XML file ``path``, gzipped or not. Raises ET.ParseError or OSError."""
    with sumolib.openz(str(path), "rb") as fh:
        return ET.parse(fh).getroot()


def root_attributes(path: str | Path) -> dict[str, str]:
    """The attributes of the root element of the XML file ``path`` (e.g. a net's ``lefthand``),
    read without parsing the rest of the file."""
    with sumolib.openz(str(path), "rb") as fh:
        for _event, element in ET.iterparse(fh, events=("start",)):
            return dict(element.attrib)
    return {}


def copy_plain(src: str | Path, dst: str | Path) -> None:
    """Copy the XML file ``src`` to ``dst``, uncompressed if ``src`` is gzipped."""
    with sumolib.openz(str(src), "rb") as fin, open(dst, "wb") as fout:
        shutil.copyfileobj(fin, fout)
