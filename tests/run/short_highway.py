"""A network for fleet tests: the shipped highway's three lanes (networks/highway.*), cut
to a length an automated vehicle inserted at its start drives within a short run."""

from __future__ import annotations

from pathlib import Path

from cosim.traffic.network import build_network


def short_highway(folder: Path, length: float) -> Path:
    """The shipped highway's three lanes, `length` m long, built in `folder`."""
    (folder / "short.nod.xml").write_text(
        f'<nodes><node id="start" x="0.0" y="11.25" type="priority"/>'
        f'<node id="end" x="{length}" y="11.25" type="priority"/></nodes>')
    (folder / "short.edg.xml").write_text(
        '<edges><edge id="highway" from="start" to="end" numLanes="3" width="3.75" '
        'spreadType="right"><lane index="0" speed="25.0"/>'
        '<lane index="1" speed="30.555555555555557"/>'
        '<lane index="2" speed="33.333333333333336"/></edge></edges>')
    return build_network(folder, "short")
