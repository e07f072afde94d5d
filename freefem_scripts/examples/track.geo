// Straight ballasted track, a quarter of it (gmsh geometry, OpenCASCADE kernel): sleepers, rail pads and one rail.
// With xStart < 0 (-spacing/2: the middle of the crib before the first sleeper) a half track instead: the first
// sleeper whole, the rail from xStart to endX (both ends in the middle of a crib), for loads that are not symmetric
// in x (a moving wheel); the labels below keep their meaning, label 2 being the rail's end face at x = xStart.
//
// Axes (metres): x along the track, y across it, z up. x = 0 is the plane of symmetry through the loaded sleeper's
// centre (the wheel stands there), y = 0 the track's centre line (the plane of symmetry between the two rails),
// z = 0 the sleepers' base (the face on the ballast). The quarter holds half of the loaded sleeper (x >= 0) and
// `sleepers - 1` whole ones at `spacing`, each half a sleeper long (y in [0, sleeperHalfLength]), and the rail over
// them to `endX` = (sleepers - 1/2) spacing, the middle of the next crib (a plane of symmetry as well: the track
// repeats by mirror images every 2 endX).
//   sleeper: a box sleeperWidth (x) by sleeperHalfLength (y) by sleeperHeight (z)
//   pad:     a box padLength (x) by railWidth (y) by padThickness (z) on each sleeper, under the rail
//   rail:    a box railWidth (y) by railHeight (z), its axis at y = railY, on the pads, from x = 0 to endX
// Physical groups (FreeFEM labels after gmshload3):
//   1  the sleepers' bases (z = 0; the interface to the ballast)     2  faces on x = 0 (symmetry)
//   3  faces on y = 0 (symmetry)     4  the rail's end face at x = endX (symmetry)     5  the rail's top face
//   6  every other outer face     7  the bottom of the subgrade layers (fixed)
//   volumes: 1 sleepers, 2 pads, 3 rail, 4 subballast, 5 formation (the layers, when their thickness is set, share
//   label 1 on their top face at z = baseZ, the ballast's base, and labels 2, 3, 4 on the planes of symmetry)
// Mesh: gmsh -3 -format msh22 -setnumber sleepers 3 ... track.geo -o track.msh (every number below can be set).
SetFactory("OpenCASCADE");

If (!Exists(sleepers))
  sleepers = 3;
EndIf
If (!Exists(xStart))
  xStart = 0;
EndIf
If (!Exists(spacing))
  spacing = 0.6;
EndIf
If (!Exists(sleeperWidth))
  sleeperWidth = 0.30;
EndIf
If (!Exists(sleeperHalfLength))
  sleeperHalfLength = 1.26;
EndIf
If (!Exists(sleeperHeight))
  sleeperHeight = 0.233;
EndIf
If (!Exists(padLength))
  padLength = 0.18;
EndIf
If (!Exists(padThickness))
  padThickness = 0.02;
EndIf
If (!Exists(railWidth))
  railWidth = 0.0352;
EndIf
If (!Exists(railHeight))
  railHeight = 0.218;
EndIf
If (!Exists(railY))
  railY = 0.75;
EndIf
If (!Exists(size))
  size = 0.08;
EndIf
If (!Exists(railSize))
  railSize = 0.03;
EndIf
// Optional subgrade layers under the ballast (FreeFEM layers instead of a soft base wall): the subballast from
// z = baseZ down by subballastThickness, the formation under it by formationThickness, across the bed's width
// bedWidth from y = 0 and along the whole quarter. 0 thickness: no layer.
If (!Exists(subballastThickness))
  subballastThickness = 0;
EndIf
If (!Exists(formationThickness))
  formationThickness = 0;
EndIf
If (!Exists(baseZ))
  baseZ = -0.3;
EndIf
If (!Exists(bedWidth))
  bedWidth = sleeperHalfLength + 0.4;
EndIf
If (!Exists(layerSize))
  layerSize = 0.12;
EndIf

endX = (sleepers - 0.5) * spacing;
padTop = sleeperHeight + padThickness;
top = padTop + railHeight;
For k In {0:sleepers - 1}
  x0 = k * spacing - 0.5 * sleeperWidth;
  If (x0 < xStart)
    x0 = xStart;
  EndIf
  Box(k + 1) = {x0, 0, 0, k * spacing + 0.5 * sleeperWidth - x0, sleeperHalfLength, sleeperHeight};
  p0 = k * spacing - 0.5 * padLength;
  If (p0 < xStart)
    p0 = xStart;
  EndIf
  Box(100 + k + 1) = {p0, railY - 0.5 * railWidth, sleeperHeight, k * spacing + 0.5 * padLength - p0, railWidth,
                      padThickness};
EndFor
Box(1000) = {xStart, railY - 0.5 * railWidth, padTop, endX - xStart, railWidth, railHeight};
layers = subballastThickness + formationThickness;
If (subballastThickness > 0)
  Box(2000) = {xStart, 0, baseZ - subballastThickness, endX - xStart, bedWidth, subballastThickness};
EndIf
If (formationThickness > 0)
  Box(2001) = {xStart, 0, baseZ - layers, endX - xStart, bedWidth, formationThickness};
EndIf
BooleanFragments{ Volume{:}; Delete; }{}
bottom = baseZ - layers;
If (layers == 0)
  bottom = 0;
EndIf

e = 1e-6;
big = 1e3;
sleeperVolumes[] = Volume In BoundingBox{xStart - e, -e, -e, endX + e, sleeperHalfLength + e, sleeperHeight + e};
padVolumes[] = Volume In BoundingBox{xStart - e, -e, sleeperHeight - e, endX + e, sleeperHalfLength + e, padTop + e};
railVolumes[] = Volume In BoundingBox{xStart - e, -e, padTop - e, endX + e, sleeperHalfLength + e, top + e};
subballastVolumes[] = Volume In BoundingBox{xStart - e, -e, baseZ - subballastThickness - e, endX + e, big, baseZ + e};
formationVolumes[] = Volume In BoundingBox{xStart - e, -e, bottom - e, endX + e, big, baseZ - subballastThickness + e};
outer[] = CombinedBoundary{ Volume{:}; };
base[] = Surface In BoundingBox{xStart - e, -e, -e, endX + e, sleeperHalfLength + e, e};
If (layers > 0)
  base[] += Surface In BoundingBox{xStart - e, -e, baseZ - e, endX + e, big, baseZ + e};
EndIf
xSymmetry[] = Surface In BoundingBox{xStart - e, -e, -big, xStart + e, big, top + e};
ySymmetry[] = Surface In BoundingBox{xStart - e, -e, -big, endX + e, e, top + e};
railEnd[] = Surface In BoundingBox{endX - e, -e, -big, endX + e, big, top + e};
railTop[] = Surface In BoundingBox{xStart - e, -e, top - e, endX + e, sleeperHalfLength + e, top + e};
layerBottom[] = {};
If (layers > 0)
  layerBottom[] = Surface In BoundingBox{xStart - e, -e, bottom - e, endX + e, big, bottom + e};
EndIf
others[] = outer[];
others[] -= base[];
others[] -= xSymmetry[];
others[] -= ySymmetry[];
others[] -= railEnd[];
others[] -= railTop[];
others[] -= layerBottom[];
Physical Surface(1) = {base[]};
Physical Surface(2) = {xSymmetry[]};
Physical Surface(3) = {ySymmetry[]};
Physical Surface(4) = {railEnd[]};
Physical Surface(5) = {railTop[]};
Physical Surface(6) = {others[]};
Physical Volume(1) = {sleeperVolumes[]};
Physical Volume(2) = {padVolumes[]};
Physical Volume(3) = {railVolumes[]};
If (layers > 0)
  Physical Surface(7) = {layerBottom[]};
EndIf
If (subballastThickness > 0)
  Physical Volume(4) = {subballastVolumes[]};
EndIf
If (formationThickness > 0)
  Physical Volume(5) = {formationVolumes[]};
EndIf

Mesh.MeshSizeMax = (layers > 0) ? layerSize : size;
MeshSize{ PointsOf{ Volume{:}; } } = size;
If (layers > 0)
  MeshSize{ PointsOf{ Volume{subballastVolumes[], formationVolumes[]}; } } = layerSize;
EndIf
MeshSize{ PointsOf{ Volume{sleeperVolumes[]}; } } = size;
MeshSize{ PointsOf{ Volume{padVolumes[], railVolumes[]}; } } = railSize;
