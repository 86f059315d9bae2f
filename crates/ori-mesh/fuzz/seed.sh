#!/usr/bin/env bash
# Seed every target's corpus with the real models (the built-in samples and ../shared/models).
set -euo pipefail
cd "$(dirname "$0")"
repo=../../..
shared=$repo/../shared/models
mkdir -p corpus/{obj,mtl,ply,gltf,glb}
cp "$shared"/stanford/bunny/bunny_npm_lowres.obj corpus/obj/
printf 'newmtl a\nKd 0.8 0.4 0.2\nmap_Kd t.png\nnewmtl b\nKd 1 1 1\nd 0.5\n' > corpus/mtl/seed.mtl
cp "$shared"/stanford/dragon/dragon_res4.ply corpus/ply/
cp "$repo"/samples/avocado/Avocado.gltf corpus/gltf/
cp "$shared"/gltf/BoxVertexColors/BoxVertexColors.glb "$shared"/gltf/VertexColorTest/VertexColorTest.glb \
   "$shared"/gltf/Duck/Duck.glb corpus/glb/
printf 'mtllib m.mtl\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 1 1 1\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nusemtl n\nf -3 -1 -2 4\n' > corpus/obj/textured.obj
