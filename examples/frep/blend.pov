// POV-Ray 3.7 scene written by caoen (frep export-pov): the model's function
// negated as an isosurface, axes swapped (caoen z up = POV-Ray y up).
#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.91140735, 0.91140735, 0.91140735> }
camera {
  perspective
  location <4.487043651820064, 3.6496349214560513, -7.299269842912103>
  right x*1.0
  up y
  sky <-0.20689040168469947, 0.9206622874969126, 0.3310246426955191>
  angle 29.999999999999996
  look_at <3.999093615345797, 3.259274892276638, -6.518549784553276>
}
global_settings { ambient_light rgb <0.06, 0.06, 0.06> max_trace_level 5 adc_bailout 1/255 }
light_source { <-6666.666666666666, 6666.666666666666, -3333.333333333333> color rgb <1, 0.96, 0.9> parallel point_at <0, 0, 0> }
light_source { <9407.208683835972, 1881.4417367671945, -2822.1626051507915> color rgb <0.175, 0.2, 0.25> parallel point_at <0, 0, 0> }
#declare caoen_m289 = function(a) { a - 289 * floor(a / 289) }
#declare caoen_perm = function(a) { caoen_m289((34 * a + 1) * a) }
#declare caoen_hash0 = function(a) { a - 16 * floor(a / 16) }
#declare caoen_hash = function(ci, cj, ck) { caoen_hash0(caoen_perm(caoen_m289(caoen_perm(caoen_m289(caoen_perm(caoen_m289(ci)) + cj)) + ck))) }
#declare caoen_grad = function(hh, x, y, z) { (1 - 2 * (hh - 2 * floor(hh / 2))) * select(hh - 8, x, y) + (1 - 2 * (floor(hh / 2) - 2 * floor(hh / 4))) * select(hh - 4, y, select(abs((hh - 12) * (hh - 14)) - 0.5, x, z)) }
#declare caoen_fade = function(a) { a * a * a * (a * (a * 6 - 15) + 10) }
#declare caoen_noise_cell = function(ci, cj, ck, x, y, z, wx, wy, wz) {
  (1 - wz) * ((1 - wy) * ((1 - wx) * caoen_grad(caoen_hash(ci, cj, ck), x, y, z) + wx * caoen_grad(caoen_hash(ci + 1, cj, ck), x - 1, y, z))
           + wy * ((1 - wx) * caoen_grad(caoen_hash(ci, cj + 1, ck), x, y - 1, z) + wx * caoen_grad(caoen_hash(ci + 1, cj + 1, ck), x - 1, y - 1, z)))
  + wz * ((1 - wy) * ((1 - wx) * caoen_grad(caoen_hash(ci, cj, ck + 1), x, y, z - 1) + wx * caoen_grad(caoen_hash(ci + 1, cj, ck + 1), x - 1, y, z - 1))
           + wy * ((1 - wx) * caoen_grad(caoen_hash(ci, cj + 1, ck + 1), x, y - 1, z - 1) + wx * caoen_grad(caoen_hash(ci + 1, cj + 1, ck + 1), x - 1, y - 1, z - 1))) }
#declare caoen_noise_at = function(ci, cj, ck, x, y, z) { caoen_noise_cell(ci, cj, ck, x, y, z, caoen_fade(x), caoen_fade(y), caoen_fade(z)) }
#declare caoen_noise = function(x, y, z, sd) { caoen_noise_at(floor(x) + sd, floor(y), floor(z), x - floor(x), y - floor(y), z - floor(z)) }
#declare caoen_union = function(p, q, k) { select(k - 1, (p + q + sqrt(max(0, p*p + q*q - 2*k*p*q))) / (1 + k), max(p, q)) }
#declare caoen_intersection = function(p, q, k) { select(k - 1, (p + q - sqrt(max(0, p*p + q*q - 2*k*p*q))) / (1 + k), min(p, q)) }
#declare caoen_blend_union = function(p, q, k, b0, b1, b2) { caoen_union(p, q, k) + b0 / (1 + (p/b1)*(p/b1) + (q/b2)*(q/b2)) }
#declare caoen_blend_intersection = function(p, q, k, b0, b1, b2) { caoen_intersection(p, q, k) + b0 / (1 + (p/b1)*(p/b1) + (q/b2)*(q/b2)) }
#declare caoen_f1 = function(x, y, z) { 0.36 - ((x - -0.5)*(x - -0.5) + (y - 0.0)*(y - 0.0) + (z - 0.0)*(z - 0.0)) }
#declare caoen_f3 = function(x, y, z) { min(0.2025 - (x - 0.5)*(x - 0.5), 0.2025 - (y - 0.0)*(y - 0.0), 0.2025 - (z - 0.0)*(z - 0.0)) }
#declare caoen_f4 = function(x, y, z) { min(0.0625 - (x - 0.5)*(x - 0.5) - (y - 0.0)*(y - 0.0), 1.0 - (z - 0.0)*(z - 0.0)) }
#declare caoen_f2 = function(x, y, z) { caoen_intersection(caoen_f3(x, y, z), -caoen_f4(x, y, z), 1.0) }
#declare caoen_f0 = function(x, y, z) { caoen_blend_union(caoen_f1(x, y, z), caoen_f2(x, y, z), 0.0, 0.3, 0.3, 0.3) }
isosurface {
  function { -caoen_f0(x, z, y) }
  contained_by { box { <-1.615575, -1.1155749999999998, -1.1155749999999998>, <1.4655749999999999, 1.1155749999999998, 1.1155749999999998> } }
  threshold 0
  accuracy 3.08115e-5
  max_gradient 2.2741360281930607
  pigment { rgbt <0.6038273, 0.21404114, 0.073238954, 0> }
  finish { ambient 1 diffuse 1 specular 0.25 roughness 0.025 }
}
