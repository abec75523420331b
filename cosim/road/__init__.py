"""The road the SV drives (not yet used by the loop): a route of SUMO edges
(`route`), the physical lanes followed along it (`tracks`), the road frame
(s, d) with exact conversions to and from the Cartesian plane (`frame`), and the
curved motorway network builder (`build`). See README "Roads".
"""
