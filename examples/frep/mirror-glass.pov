// POV-Ray 3.7 scene written by caoen (frep export-pov): the model's function
// negated as an isosurface, axes swapped (caoen z up = POV-Ray y up).
#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.5225215, 0.6038273, 0.7484141> }
camera {
  perspective
  location <1.5799538534078075, 3.9627384801915047, -7.22264618700712>
  right x*1.0
  up y
  sky <-0.10291353143183149, 0.8763985652885333, 0.4704618579740868>
  angle 29.999999999999996
  look_at <1.392670215416089, 3.4811519824985147, -6.366492413330693>
}
global_settings { ambient_light rgb <0.050876077, 0.050876077, 0.050876077> max_trace_level 5 adc_bailout 1/255 }
light_source { <-4649.905549752772, 8137.33471206735, -3487.4291623145787> color rgb <1, 0.9331069, 0.8275708> parallel point_at <0, 0, 0> }
light_source { <8111.071056538127, 4866.6426339228765, -3244.428422615251> color rgb <0.15675646, 0.19148494, 0.3> parallel point_at <0, 0, 0> }
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
#declare caoen_f0 = function(x, y, z) { min(2.25 - (x - 0.0)*(x - 0.0), 1.44 - (y - 0.0)*(y - 0.0), 0.0025000000000000005 - (z - -0.55)*(z - -0.55)) }
isosurface {
  function { -caoen_f0(x, z, y) }
  contained_by { box { <-1.503, -0.6030000000000001, -1.2029999999999998>, <1.503, -0.497, 1.2029999999999998> } }
  threshold 0
  accuracy 3.006e-5
  max_gradient 3.7575
  pigment { rgbt <0.63828313, 0.6038273, 0.5070784, 0> }
  finish { ambient 1 diffuse 1 specular 0 roughness 0.025 }
}
#declare caoen_f1 = function(x, y, z) { 0.2025 - ((x - -0.6)*(x - -0.6) + (y - 0.35)*(y - 0.35) + (z - -0.05)*(z - -0.05)) }
isosurface {
  function { -caoen_f1(x, z, y) }
  contained_by { box { <-1.0509, -0.5009, -0.10090000000000003>, <-0.14909999999999995, 0.40090000000000003, 0.8009000000000001> } }
  threshold 0
  accuracy 9.018e-6
  max_gradient 1.1852050112538222
  pigment { rgbt <0.019606646, 0.019606646, 0.019606646, 0> }
  finish { ambient 1 diffuse 1 specular 0.6 roughness 0.0125 reflection { 0.85 } }
}
#declare caoen_f2 = function(x, y, z) { 0.0484 - ((x - 0.35)*(x - 0.35) + (y - 0.75)*(y - 0.75) + (z - -0.28)*(z - -0.28)) }
isosurface {
  function { -caoen_f2(x, z, y) }
  contained_by { box { <0.12955999999999998, -0.50044, 0.52956>, <0.57044, -0.05956000000000002, 0.97044> } }
  threshold 0
  accuracy 4.4088e-6
  max_gradient 0.5794335610574239
  pigment { rgbt <0.6038273, 0.019606646, 0.010022824, 0> }
  finish { ambient 1 diffuse 1 specular 0.3 roughness 0.025 }
}
#declare caoen_f3 = function(x, y, z) { ln(2.0 / max(exp(12.0 * ((0.0*(x - 0.45) + -1.752437040397112*(y - -0.15) + -2.8355026945068*(z - -0.16)) - 1)) + exp(12.0 * ((-2.8355026945068*(x - 0.45) + 0.0*(y - -0.15) + -1.752437040397112*(z - -0.16)) - 1)) + exp(12.0 * ((-1.752437040397112*(x - 0.45) + -2.8355026945068*(y - -0.15) + 0.0*(z - -0.16)) - 1)) + exp(12.0 * ((0.0*(x - 0.45) + -1.752437040397112*(y - -0.15) + 2.8355026945068*(z - -0.16)) - 1)) + exp(12.0 * ((2.8355026945068*(x - 0.45) + 0.0*(y - -0.15) + -1.752437040397112*(z - -0.16)) - 1)) + exp(12.0 * ((-1.752437040397112*(x - 0.45) + 2.8355026945068*(y - -0.15) + 0.0*(z - -0.16)) - 1)) + exp(12.0 * ((0.0*(x - 0.45) + 1.7524370403971123*(y - -0.15) + -2.8355026945068005*(z - -0.16)) - 1)) + exp(12.0 * ((-2.8355026945068*(x - 0.45) + 0.0*(y - -0.15) + 1.752437040397112*(z - -0.16)) - 1)) + exp(12.0 * ((1.752437040397111*(x - 0.45) + -2.835502694506799*(y - -0.15) + 0.0*(z - -0.16)) - 1)) + exp(12.0 * ((0.0*(x - 0.45) + 1.7524370403971123*(y - -0.15) + 2.8355026945068005*(z - -0.16)) - 1)) + exp(12.0 * ((2.8355026945068*(x - 0.45) + 0.0*(y - -0.15) + 1.752437040397112*(z - -0.16)) - 1)) + exp(12.0 * ((1.7524370403971117*(x - 0.45) + 2.8355026945067996*(y - -0.15) + 0.0*(z - -0.16)) - 1)), 1e-300)) }
isosurface {
  function { -caoen_f3(x, z, y) }
  contained_by { box { <0.04987221118126045, -0.5601277888187396, -0.5501277888187396>, <0.8501277888187395, 0.24012778881873956, 0.2501277888187396> } }
  threshold 0
  accuracy 8.002555776374793e-6
  max_gradient 49.905517921424554
  pigment { rgbt <0.8275708, 0.91140735, 1, 0.9> }
  finish { ambient 1 diffuse 1 specular 0.6 roughness 0.008333333333333333 reflection { 0, 1 fresnel on } conserve_energy }
  interior { ior 1.5 }
}
