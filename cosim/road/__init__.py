"""The road the SV drives (the loop uses it to check `[road] route` and for trace.csv's
s_m, d_m, edge, track; it does not drive curves yet): a route of SUMO edges
(`route`), the physical lanes followed along it (`tracks`), the road frame
(s, d) with exact conversions to and from the Cartesian plane (`frame`), and the
curved motorway network builder (`build`). See docs/roads.md.
"""
