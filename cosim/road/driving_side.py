"""Which side of the road a SUMO network's traffic keeps to.

netconvert --lefthand writes `lefthand="true"` on the network's root `<net>` element:
SUMO then numbers lanes from the left and drives on the left, and every lane shape is
mirrored. cosim drives right-hand traffic only (lane 0 the rightmost, acceleration
lanes on the right), so such a network is refused by name when it is read, before its
mirrored lanes could show up as a deviation or a misplaced lane. sumolib does not keep
the attribute, so the root is read here, as SUMO reads the file (gzipped or not).
"""

from __future__ import annotations

import gzip
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

# SUMO's true words for a bool attribute (StringUtils::toBool, case-insensitive)
_TRUE = frozenset({"1", "yes", "true", "on", "x"})
_CHUNK = 1 << 16  # bytes read at a time until the root element's start tag is complete
_HEAD = 1 << 22  # bytes read at most: the root comes after a header comment only

LEFT_HAND = "left-hand traffic (netconvert --lefthand) is not supported"


def left_hand(path: Path | str) -> bool:
    """The network at `path` says lefthand="true" (SUMO's bool words) on its root; False
    for right-hand traffic and for a file that cannot be read (its readers say why)."""
    parser = ET.XMLPullParser(events=("start",))
    try:
        with open(path, "rb") as raw:
            packed = raw.read(2) == b"\x1f\x8b"
        with (gzip.open(path, "rb") if packed else open(path, "rb")) as fh:
            for _ in range(_HEAD // _CHUNK):
                chunk = fh.read(_CHUNK)
                if not chunk:
                    break
                parser.feed(chunk)
                for _, root in parser.read_events():
                    return str(root.get("lefthand", "false")).strip().lower() in _TRUE
    except (OSError, EOFError, ET.ParseError, zlib.error, ValueError):
        return False
    return False


def left_hand_refusal(path: Path | str) -> str:
    """What a refusal of the left-hand network at `path` says allowed."""
    return (f"{LEFT_HAND}: a network for right-hand traffic ({Path(path).name} says "
            'lefthand="true" on its <net>)')
