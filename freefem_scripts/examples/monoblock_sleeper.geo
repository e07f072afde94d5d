// Concrete monoblock sleeper of the B70 type (gmsh geometry, built-in kernel): tapered in height, trapezoidal section.
//
// Outline (x along the sleeper, y across it, z up; the base at z = 0, centred on y = 0), metres:
//   length 2.60, base width 0.30, height 0.214 under the rail seats and towards the ends, 0.175 over the middle
//   0.40 m, linear tapers 0.20 m long between; the top is 0.17 m wide (the sides slope inwards). Rail seats 0.15 m
//   long (the foot of a UIC60 rail) centred 1.50 m apart (standard gauge, rail axes), at x = 0.55 and 2.05.
//   Length, base width and the two heights are the B70's nominal ones (DB; EN 13230-2 monoblock); the top width,
//   the taper lengths and the flat rail seats (no 1:40 inclination, no dowels, no rounded edges) are simplified.
// Physical groups (FreeFEM labels after gmshload3):
//   1  base (the face that rests on the ballast; the interface to the particles)
//   2  the two rail seats on the top face
//   3  every other face (sides, ends, the rest of the top)
//   volume 1
// Mesh: gmsh -3 -format msh22 -setnumber size 0.05 monoblock_sleeper.geo -o monoblock_sleeper.msh
// (`size` [m]: target element size; tools: freefem_scripts/studies/sleeper_mesh_convergence.py).

If (!Exists(size))
  size = 0.05;
EndIf

stations[] = {0, 0.475, 0.625, 0.9, 1.1, 1.5, 1.7, 1.975, 2.125, 2.6};      // x [m] of the cross-sections
heights[] = {0.214, 0.214, 0.214, 0.214, 0.175, 0.175, 0.214, 0.214, 0.214, 0.214};  // [m] at each station
halfBase = 0.15;
halfTop = 0.085;
count = #stations[];

// Corners of section i: 4i+1 (y = -halfBase, base), 4i+2 (+halfBase, base), 4i+3 (+halfTop, top), 4i+4 (-halfTop, top).
For i In {0:count - 1}
  Point(4 * i + 1) = {stations[i], -halfBase, 0, size};
  Point(4 * i + 2) = {stations[i], halfBase, 0, size};
  Point(4 * i + 3) = {stations[i], halfTop, heights[i], size};
  Point(4 * i + 4) = {stations[i], -halfTop, heights[i], size};
  For k In {0:3}
    Line(100 * i + k + 1) = {4 * i + k + 1, 4 * i + (k + 1) % 4 + 1};  // edge k of section i
  EndFor
EndFor
For i In {0:count - 2}
  For k In {0:3}
    Line(10000 + 10 * i + k + 1) = {4 * i + k + 1, 4 * (i + 1) + k + 1};  // along x from section i to i + 1
  EndFor
EndFor

// Faces between sections i and i + 1: side k = 0 base, 1 side at +y, 2 top, 3 side at -y.
base[] = {};
seats[] = {};
others[] = {};
For i In {0:count - 2}
  For k In {0:3}
    Curve Loop(20000 + 10 * i + k + 1) = {100 * i + k + 1, 10000 + 10 * i + (k + 1) % 4 + 1,
                                          -(100 * (i + 1) + k + 1), -(10000 + 10 * i + k + 1)};
    Surface(20000 + 10 * i + k + 1) = {20000 + 10 * i + k + 1};
    If (k == 0)
      base[] += {20000 + 10 * i + k + 1};
    ElseIf (k == 2 && (i == 1 || i == 7))
      seats[] += {20000 + 10 * i + k + 1};
    Else
      others[] += {20000 + 10 * i + k + 1};
    EndIf
  EndFor
EndFor
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
last = 100 * (count - 1);
Curve Loop(2) = {last + 1, last + 2, last + 3, last + 4};
Plane Surface(2) = {2};
others[] += {1, 2};

Surface Loop(1) = {base[], seats[], others[]};
Volume(1) = {1};

Physical Surface(1) = {base[]};
Physical Surface(2) = {seats[]};
Physical Surface(3) = {others[]};
Physical Volume(1) = {1};
