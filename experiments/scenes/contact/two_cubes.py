"""Writes two_cubes.mesh and two_cubes_fine.mesh (MEDIT): two 0.2 m cubes of n x n x n cells
(6 tets per cell: n = 4 gives 384 tets each, n = 9 gives 4,374) in one mesh, the upper one
0.1 m above the lower and shifted sideways, so that one body is made of two disconnected
pieces (self-contact between them is what stops the upper one). Run: python3 two_cubes.py"""
import sys

def cube(origin, size, n):
    verts, tets = [], []
    idx = lambda i, j, k: i + (n + 1) * (j + (n + 1) * k)
    for k in range(n + 1):
        for j in range(n + 1):
            for i in range(n + 1):
                verts.append(tuple(o + size * c / n for o, c in zip(origin, (i, j, k))))
    # Kuhn split of each cell into 6 tets along the main diagonal (all positively oriented
    # when listed as below; the scene sets mesh.reorient = true to be safe).
    paths = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    for k in range(n):
        for j in range(n):
            for i in range(n):
                for p in paths:
                    c = [i, j, k]
                    t = [idx(*c)]
                    for axis in p:
                        c[axis] += 1
                        t.append(idx(*c))
                    tets.append(t)
    return verts, tets

def write(name, n):
  v1, t1 = cube((0.0, 0.0, 0.0), 0.2, n)
  v2, t2 = cube((0.06, 0.3, 0.04), 0.2, n)
  off = len(v1)
  verts = v1 + v2
  tets = t1 + [[a + off for a in t] for t in t2]
  with open(name, "w") as f:
      f.write("MeshVersionFormatted 1\nDimension 3\nVertices\n%d\n" % len(verts))
      for v in verts:
          f.write("%.6f %.6f %.6f 0\n" % v)
      f.write("Tetrahedra\n%d\n" % len(tets))
      for t in tets:
          f.write("%d %d %d %d 0\n" % tuple(a + 1 for a in t))
      f.write("End\n")

write("two_cubes.mesh", 4)
write("two_cubes_fine.mesh", 9)
