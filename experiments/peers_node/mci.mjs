// ITK MorphologicalContourInterpolator (the filter behind 3D Slicer's
// "Fill between slices") via @itk-wasm/morphological-contour-interpolation
// (WASI build run in node).
//
// usage: node mci.mjs in.raw out.raw NX NY NZ [--axis 2] [--label 1]
//        [--slices i,j,k]   (use custom slice positions: these z indices are
//                            the labelled slices, empty ones included)
//        [--no-extrapolation] [--no-heuristic] [--no-dt] [--ball]
// in.raw: uint8 labels, C order (z, y, x), i.e. x fastest (ITK order).
// Prints one JSON line: {"seconds": wasm pipeline time, ...}.
import fs from 'fs'
import { morphologicalContourInterpolationNode } from '@itk-wasm/morphological-contour-interpolation'

const argv = process.argv.slice(2)
const [inPath, outPath, nx, ny, nz] = [argv[0], argv[1], +argv[2], +argv[3], +argv[4]]
const opt = { axis: 2, label: 1 }
for (let i = 5; i < argv.length; i++) {
  const a = argv[i]
  if (a === '--axis') opt.axis = +argv[++i]
  else if (a === '--label') opt.label = +argv[++i]
  else if (a === '--slices') {
    opt.useCustomSlicePositions = true
    opt.labeledSliceIndicesAxis = 2
    opt.labeledSliceIndicesLabel = opt.label
    opt.labeledSliceIndices = argv[++i].split(',').map(Number)
  } else if (a === '--no-extrapolation') opt.noUseExtrapolation = true
  else if (a === '--no-heuristic') opt.noHeuristicAlignment = true
  else if (a === '--no-dt') opt.noUseDistanceTransform = true
  else if (a === '--ball') opt.useBallStructuringElement = true
  else throw new Error('unknown option ' + a)
}
const buf = fs.readFileSync(inPath)
if (buf.length !== nx * ny * nz) throw new Error(`size ${buf.length} != ${nx}*${ny}*${nz}`)
const image = {
  imageType: { dimension: 3, componentType: 'uint8', pixelType: 'Scalar', components: 1 },
  name: 'labels',
  origin: [0, 0, 0],
  spacing: [1, 1, 1],
  direction: new Float64Array([1, 0, 0, 0, 1, 0, 0, 0, 1]),
  size: [nx, ny, nz],
  metadata: new Map(),
  data: new Uint8Array(buf.buffer, buf.byteOffset, buf.length),
}
const t0 = performance.now()
const { outputImage } = await morphologicalContourInterpolationNode(image, opt)
const t1 = performance.now()
const out = outputImage.data
if (out.length !== nx * ny * nz) throw new Error(`output has ${out.length} pixels`)
fs.writeFileSync(outPath, Buffer.from(out.buffer, out.byteOffset, out.byteLength))
console.log(JSON.stringify({ seconds: (t1 - t0) / 1000, componentType: outputImage.imageType.componentType,
  size: outputImage.size, options: opt }))
