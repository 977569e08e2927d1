// Same-machine calibration for bench_scale.py (not part of signorini, not built by CI): how far the
// boxes of Box3D's large_pyramid (100-box base, 5,050 unit cubes of density 100, on a static slab,
// sleeping off) move from their starting positions under Box3D's own solver, so that bench_scale
// can print Box3D's "max disp m" beside ours with the same rule (a pyramid stands when every box
// stays within 1 cm of its start). Written against Box3D's public API (box3d/box3d.h); the scene
// follows the layout of Box3D's shared/benchmarks.c CreateLargePyramid.
//
// Build, given a Box3D checkout at $B built with CMake in $B/build (its benchmark app's build):
//   cc -O2 -I$B/include benchmarks/box3d/pyramid_sag.c $B/build/src/libbox3d.a -lm -lpthread -o pyramid_sag
// Run:   ./pyramid_sag STEPS SUBSTEPS HZ [RECYCLE]   (default 600 steps, 4 substeps, 60 Hz, Box3D's
//        contact recycle distance; RECYCLE 0 switches its contact recycling off)
// Prints one line per simulated second and a last line
//   result steps=S max_disp=M top_dz=Z boxes_over_1cm=C in_plane=X out_of_plane=Y
// with M, Z, X and Y in metres (Z: the top box's vertical displacement, negative when it sank; X, Y:
// the largest horizontal displacement in the pyramid's plane and out of it).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "box3d/box3d.h"

enum { kBase = 100, kBoxes = kBase * (kBase + 1) / 2 };

static b3BodyId g_ids[kBoxes];
static b3Pos g_start[kBoxes];

static double in_plane(int k) { return fabs(b3Body_GetPosition(g_ids[k]).x - g_start[k].x); }
static double out_of_plane(int k) { return fabs(b3Body_GetPosition(g_ids[k]).z - g_start[k].z); }

static double displacement(int k) {
  b3Pos p = b3Body_GetPosition(g_ids[k]);
  double dx = p.x - g_start[k].x, dy = p.y - g_start[k].y, dz = p.z - g_start[k].z;
  return sqrt(dx * dx + dy * dy + dz * dz);
}

int main(int argc, char** argv) {
  int steps = argc > 1 ? atoi(argv[1]) : 600;
  int substeps = argc > 2 ? atoi(argv[2]) : 4;
  float hz = argc > 3 ? (float)atof(argv[3]) : 60.0f;
  float recycle = argc > 4 ? (float)atof(argv[4]) : -1.0f;
  if (steps < 1 || substeps < 1 || !(hz > 0.0f)) {
    fprintf(stderr, "usage: pyramid_sag [STEPS >= 1] [SUBSTEPS >= 1] [HZ > 0] [RECYCLE >= 0]\n");
    return 2;
  }
  b3WorldDef world_def = b3DefaultWorldDef();
  world_def.enableSleep = false;
  b3WorldId world = b3CreateWorld(&world_def);
  if (recycle >= 0.0f) b3World_SetContactRecycleDistance(world, recycle);
  {
    b3BodyDef ground_def = b3DefaultBodyDef();
    ground_def.position = (b3Pos){0.0f, -1.0f, 0.0f};
    b3BodyId ground = b3CreateBody(world, &ground_def);
    b3BoxHull slab = b3MakeBoxHull(400.0f, 1.0f, 400.0f);
    b3ShapeDef shape_def = b3DefaultShapeDef();
    b3CreateHullShape(ground, &shape_def, &slab.base);
  }
  b3BodyDef body_def = b3DefaultBodyDef();
  body_def.type = b3_dynamicBody;
  b3ShapeDef shape_def = b3DefaultShapeDef();
  shape_def.density = 100.0f;
  const float h = 0.5f;  // half extent (m)
  b3BoxHull cube = b3MakeBoxHull(h, h, h);
  int count = 0;
  for (int i = 0; i < kBase; ++i) {  // layer i, from the ground up
    for (int j = i; j < kBase; ++j) {
      body_def.position = (b3Pos){(i + 1.0f) * h + 2.0f * (j - i) * h - h * kBase, (2.0f * i + 1.0f) * h, 0.0f};
      g_ids[count] = b3CreateBody(world, &body_def);
      b3CreateHullShape(g_ids[count], &shape_def, &cube.base);
      g_start[count] = body_def.position;
      ++count;
    }
  }
  double worst = 0.0, top_dz = 0.0, x = 0.0, y = 0.0;
  int over = 0;
  for (int s = 1; s <= steps; ++s) {
    b3World_Step(world, 1.0f / hz, substeps);
    if (s % (int)hz != 0 && s != steps) continue;
    worst = x = y = 0.0;
    over = 0;
    for (int k = 0; k < count; ++k) {
      double d = displacement(k), dx = in_plane(k), dy = out_of_plane(k);
      worst = d > worst ? d : worst;
      x = dx > x ? dx : x;
      y = dy > y ? dy : y;
      over += d > 0.01;
    }
    top_dz = b3Body_GetPosition(g_ids[count - 1]).y - g_start[count - 1].y;
    printf("t=%.2f s: max_disp=%.4f m top_dz=%.4f m boxes_over_1cm=%d in_plane=%.4f m out_of_plane=%.4f m\n", s / hz,
           worst, top_dz, over, x, y);
  }
  printf("result steps=%d max_disp=%.6f top_dz=%.6f boxes_over_1cm=%d in_plane=%.6f out_of_plane=%.6f\n", steps, worst,
         top_dz, over, x, y);
  b3DestroyWorld(world);
  return 0;
}
