"""The two fused numba passes that turn sampled tissue into a B-mode image.

`scan_lines` (one thread per column, i.e. per scan line, walking down it):
  tissue properties per pixel (vessel walls overriding the sampled material inside the wall
  band), round-trip attenuation accumulated down the line, transmission loss and a specular
  echo at every impedance step (vessel-wall echoes weighted by the incidence angle on the
  surface nearest the step's wall pixel, which runs parallel to the wall), air after
  tissue stopping the line, each specular echo's reverberation (see the function), optional
  side-lobe clutter (`lateral_clutter`, computed before: a share of the scatter power of the
  tissue beside each pixel and across its row); the reflectivity
  (echogenicity times the phantom-fixed scatterer field summed over the elevational slice,
  plus specular echoes) is then convolved with the axial pulse. Output: the analytic (IQ)
  echo signal before time-gain compensation.

`form_image` (one thread per column again): the lateral beam, one Gaussian kernel per row;
electronic noise (a hash of the pixel and a frame key, so a given pose always gives the same
image); time-gain compensation; envelope; log compression to grey levels; the grey map;
black where the column has no skin contact or the pixel lies in air, with the label image
masked alike. `smooth_lines` then applies the scanner's speckle reduction, if any.

Arrays indexed `[col, row]` are column-major scan lines: `material[col * rows + row]` is the
sample of pixel (col, row).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sim.ultrasound.scatterers import (
    FIELD_COMPONENT_VARIANCE,
    VALUE_SAFE_FASTMATH,
    accumulate_coordinates,
    accumulate_line,
    mix32,
    unit_pair,
)

_TINY_POWER = np.float32(1e-30)
_LOG2_POLY = (
    np.float32(1.53914771e-01),
    np.float32(-5.67755742e-01),
    np.float32(1.41348792e00),
    np.float32(1.33410354e-03),
)
"""Cubic least-squares fit of log2(1 + t) on [0, 1), highest power first; error < 0.0014
(0.004 dB, against 0.2 dB per grey level)."""
_TEXTURE_NORMALISER = 1.0 / math.sqrt(FIELD_COMPONENT_VARIANCE)
"""Scales the texture field to unit variance per component."""
_INVERSE_RIDGE_WIDTH = np.float32(1.0 / 0.15)
"""Ridges are where the unit-variance texture component lies within about 0.15 of zero:
some 12 % of the tissue, in lines a tenth of the texture lattice spacing wide."""
_MANTISSA = np.int32(0x007FFFFF)
_ONE_BITS = np.int32(0x3F800000)
_EXPONENT_BIAS = np.int32(127)
_MANTISSA_BITS = np.int32(23)


@numba.njit(fastmath=VALUE_SAFE_FASTMATH, cache=True)
def fast_log2(values: np.ndarray) -> np.ndarray:
    """log2 of positive normal float32 values from their exponent bits and a cubic in the
    mantissa: vectorises, unlike the libm call (no SVML here)."""
    bits = values.view(np.int32)
    mantissa_bits = np.empty_like(bits)
    for n in range(bits.shape[0]):
        mantissa_bits[n] = (bits[n] & _MANTISSA) | _ONE_BITS
    mantissa = mantissa_bits.view(np.float32)
    out = np.empty_like(values)
    c3, c2, c1, c0 = _LOG2_POLY
    for n in range(bits.shape[0]):
        t = mantissa[n] - np.float32(1.0)
        exponent = np.float32((bits[n] >> _MANTISSA_BITS) - _EXPONENT_BIAS)
        out[n] = exponent + ((c3 * t + c2) * t + c1) * t + c0
    return out


@numba.njit(cache=True, parallel=True)
def grid_points(
    origin: np.ndarray, col_step: np.ndarray, row_step: np.ndarray, rows: int, out: np.ndarray
) -> None:
    """Phantom-frame pixel centres, column-major: `out[col * rows + row] = origin + col *
    col_step + row * row_step`."""
    cols = out.shape[0] // rows
    for col in numba.prange(cols):
        for row in range(rows):
            n = col * rows + row
            for axis in range(3):
                out[n, axis] = origin[axis] + col * col_step[axis] + row * row_step[axis]


@numba.njit(fastmath=VALUE_SAFE_FASTMATH, cache=True)
def lateral_clutter(
    material: np.ndarray,
    echogenicity: np.ndarray,
    rows: int,
    power: float,
    half_cols: int,
    spread: float,
    cumulative: np.ndarray,
    out: np.ndarray,
) -> None:
    """Side-lobe clutter per pixel, `out[col * rows + row]` = `power` times the mean squared
    echogenicity of the pixels in the same row (air counts as 0), a share `spread` of it over
    the whole row and the rest within `half_cols` columns: the side lobes pick up the tissue
    beside a lumen at the lumen's own depth, the far lobes and reverberation tissue anywhere
    in the image. Running sums over the columns, each column's rows contiguous; `cumulative`
    is a (cols + 1, rows) float32 work buffer."""
    cols = out.shape[0] // rows
    cumulative[0, :] = 0.0
    for col in range(cols):
        for row in range(rows):
            m = material[col * rows + row]
            value = echogenicity[m] if m >= 0 else np.float32(0.0)
            cumulative[col + 1, row] = cumulative[col, row] + value * value
    whole_row = np.float32(power * spread / cols)
    for col in range(cols):
        low = max(0, col - half_cols)
        high = min(cols, col + half_cols + 1)
        near = np.float32(power * (1.0 - spread) / (high - low))
        for row in range(rows):
            window = cumulative[high, row] - cumulative[low, row]
            out[col * rows + row] = near * window + whole_row * cumulative[cols, row]


@numba.njit(parallel=True, fastmath=VALUE_SAFE_FASTMATH, cache=True)
def scan_lines(
    origin: np.ndarray,
    col_step: np.ndarray,
    row_step: np.ndarray,
    deformed: bool,
    points: np.ndarray,
    elevation_dir: np.ndarray,
    elevation_offsets: np.ndarray,
    elevation_weights: np.ndarray,
    material: np.ndarray,
    vessel_distance: np.ndarray,
    vessel_normal: np.ndarray,
    vessel_index: np.ndarray,
    wall_thickness: np.ndarray,
    echogenicity: np.ndarray,
    round_trip_step: np.ndarray,
    impedance: np.ndarray,
    contact: np.ndarray,
    pulse: np.ndarray,
    inverse_spacing: float,
    seed: np.uint32,
    specular_gain: float,
    specular_exponent: float,
    reverberation: float,
    has_clutter: bool,
    clutter: np.ndarray,
    has_texture: bool,
    texture_inverse_scale: np.ndarray,
    texture_seed: np.uint32,
    texture_variation: np.ndarray,
    texture_ridges: np.ndarray,
    out_real: np.ndarray,
    out_imag: np.ndarray,
) -> None:
    """IQ echo signal of every scan line into `out_real`, `out_imag` (cols, rows).

    `origin`, `col_step`, `row_step`: phantom-frame position of pixel (0, 0) and the steps to
    the next column and row; the beam runs along `row_step`. When `deformed`, the tissue seen
    at each pixel is at `points` (column-major, the undeformed points the tissue moved from)
    rather than on that lattice, and the scatterer and texture fields are read there, so the
    speckle moves with the tissue. Material tables (`echogenicity`,
    `round_trip_step` = amplitude factor of attenuation over one row there and back,
    `impedance`) have the vessel-wall material appended after the phantom's materials.
    `clutter` (pixels, column-major): scatter power added before attenuation, when `has_clutter`.
    Reverberation: an echo from depth d that the transducer face reflects (coefficient
    `reverberation`) goes back to the interface and returns as if from depth 2d, weaker by the
    interface's reflection and the round trip's attenuation once more: ghost = `reverberation`
    x specular(d)^2 / `specular_gain`, split between the two rows around 2d (row r's centre
    lies r + 1/2 pixels below the face). First order only: each higher order is weaker by the
    same factor again.
    Texture (when `has_texture`): a second hashed field on a lattice of spacing
    1 / `texture_inverse_scale` (per axis, phantom frame); its real part varies each material's
    scatter amplitude log-normally by `texture_variation` (nepers, mean power kept), its
    imaginary part's zero crossings add `texture_ridges` of echogenicity (see `Material`).
    """
    cols, rows = out_real.shape
    wall = echogenicity.shape[0] - 1
    half = pulse.shape[0] // 2
    step = math.sqrt(row_step[0] ** 2 + row_step[1] ** 2 + row_step[2] ** 2)
    bx, by, bz = row_step[0] / step, row_step[1] / step, row_step[2] / step
    lattice_step = row_step * inverse_spacing
    for col in numba.prange(cols):
        start = np.empty(3)
        amplitude = np.zeros(rows, dtype=np.float32)
        specular = np.zeros(rows, dtype=np.float32)
        reflect_re = np.zeros(rows, dtype=np.float32)
        reflect_im = np.zeros(rows, dtype=np.float32)
        texture_re = np.zeros(rows, dtype=np.float32)
        texture_im = np.zeros(rows, dtype=np.float32)
        if deformed:  # the column's tissue points, one contiguous array per axis
            tissue = np.empty((3, rows))
            for row in range(rows):
                for axis in range(3):
                    tissue[axis, row] = points[col * rows + row, axis]
            lattice = np.empty((3, rows), dtype=np.float32)
        if contact[col] and has_texture and deformed:
            for axis in range(3):
                for row in range(rows):  # element by element: no temporary arrays per column
                    lattice[axis, row] = texture_inverse_scale[axis] * tissue[axis, row]
            accumulate_coordinates(
                lattice[0],
                lattice[1],
                lattice[2],
                _TEXTURE_NORMALISER,
                texture_seed,
                texture_re,
                texture_im,
            )
        elif contact[col] and has_texture:
            for axis in range(3):
                start[axis] = texture_inverse_scale[axis] * (origin[axis] + col * col_step[axis])
            accumulate_line(
                start,
                row_step * texture_inverse_scale,
                _TEXTURE_NORMALISER,
                texture_seed,
                texture_re,
                texture_im,
            )
        if contact[col]:
            gain = np.float32(1.0)  # round-trip amplitude left after attenuation and interfaces
            previous: int | np.int64 = -1  # previous pixel's effective material (-1 before tissue)
            for row in range(rows):
                n = col * rows + row
                m = np.int64(material[n])
                if m < 0:
                    if previous >= 0:  # tissue then air: total reflection, nothing beyond
                        specular[row] = -specular_gain * gain
                        break
                    continue  # coupling gel between the face and the skin
                v = np.int64(vessel_index[n])
                in_wall = v >= 0 and 0.0 <= vessel_distance[n] <= wall_thickness[v]
                if in_wall:
                    m = wall
                if previous >= 0 and m != previous:
                    z1 = impedance[previous]
                    z2 = impedance[m]
                    r = (z2 - z1) / (z2 + z1)
                    incidence = np.float32(1.0)
                    if m == wall or previous == wall:  # the wall pixel's nearest surface
                        w = n if m == wall else n - 1
                        cosine = abs(
                            bx * vessel_normal[w, 0]
                            + by * vessel_normal[w, 1]
                            + bz * vessel_normal[w, 2]
                        )
                        incidence = np.float32(cosine**specular_exponent)
                    specular[row] = specular_gain * r * incidence * gain
                    gain *= np.float32(1.0) - r * r
                gain *= round_trip_step[m]
                scatter = echogenicity[m]
                if has_texture:
                    variation = texture_variation[m]
                    if variation > 0:
                        scatter *= np.float32(math.exp(variation * (texture_re[row] - variation)))
                    if texture_ridges[m] > 0:
                        ridge = texture_im[row] * _INVERSE_RIDGE_WIDTH
                        scatter += texture_ridges[m] * np.float32(math.exp(-ridge * ridge))
                if has_clutter:
                    scatter = np.float32(math.sqrt(scatter * scatter + clutter[n]))
                amplitude[row] = scatter * gain
                previous = m
            for e in range(elevation_offsets.shape[0]):
                offset = elevation_offsets[e]
                if deformed:
                    for axis in range(3):
                        across = offset * elevation_dir[axis]
                        for row in range(rows):
                            lattice[axis, row] = inverse_spacing * (tissue[axis, row] + across)
                    accumulate_coordinates(
                        lattice[0],
                        lattice[1],
                        lattice[2],
                        elevation_weights[e],
                        seed,
                        reflect_re,
                        reflect_im,
                    )
                    continue
                for axis in range(3):
                    start[axis] = inverse_spacing * (
                        origin[axis] + col * col_step[axis] + offset * elevation_dir[axis]
                    )
                accumulate_line(
                    start, lattice_step, elevation_weights[e], seed, reflect_re, reflect_im
                )
            if reverberation > 0 and specular_gain > 0:  # deepest first: no ghost of a ghost
                for row in range(rows // 2 - 1, -1, -1):
                    ghost = np.float32(reverberation) * specular[row] * specular[row]
                    ghost /= np.float32(specular_gain)
                    specular[2 * row] += np.float32(0.5) * ghost
                    specular[2 * row + 1] += np.float32(0.5) * ghost
            for row in range(rows):
                reflect_re[row] = amplitude[row] * reflect_re[row] + specular[row]
                reflect_im[row] *= amplitude[row]
        line_re = out_real[col]
        line_im = out_imag[col]
        line_re[:] = 0.0
        line_im[:] = 0.0
        for t in range(pulse.shape[0]):
            kr = pulse[t].real
            ki = pulse[t].imag
            shift = half - t
            for row in range(max(0, -shift), min(rows, rows - shift)):
                source = row + shift
                line_re[row] += kr * reflect_re[source] - ki * reflect_im[source]
                line_im[row] += kr * reflect_im[source] + ki * reflect_re[source]


@numba.njit(parallel=True, fastmath=VALUE_SAFE_FASTMATH, cache=True)
def form_image(
    echo_real: np.ndarray,
    echo_imag: np.ndarray,
    lateral: np.ndarray,
    tgc: np.ndarray,
    noise_amplitude: float,
    frame_key: np.uint32,
    grey_per_log2: float,
    grey_offset: float,
    grey_map: np.ndarray,
    material: np.ndarray,
    label: np.ndarray,
    contact: np.ndarray,
    line_gain: np.ndarray,
    image: np.ndarray,
    label_image: np.ndarray,
) -> None:
    """B-mode `image` and masked `label_image`, both (cols, rows) uint8 (transpose for display),
    from the IQ scan lines.

    `lateral` (taps, rows): the per-row lateral beam; `line_gain` (cols,): each line's echo
    amplitude factor (its aperture's coupling), before the receiver's noise is added; `tgc`
    (rows,): time-gain compensation (amplitude factors). Grey level =
    `grey_per_log2 * log2(envelope^2) + grey_offset`, clipped, then looked up in `grey_map`
    (256 uint8 entries).
    """
    cols, rows = echo_real.shape
    grey_scale = np.float32(grey_per_log2)
    grey_base = np.float32(grey_offset)
    taps = lateral.shape[0]
    half = taps // 2
    for col in numba.prange(cols):
        if not contact[col]:
            image[col, :] = 0
            label_image[col, :] = 0
            continue
        acc_re = np.zeros(rows, dtype=np.float32)
        acc_im = np.zeros(rows, dtype=np.float32)
        for t in range(max(0, col + half - cols + 1), min(taps, col + half + 1)):
            kernel = lateral[t]
            source_re = echo_real[col + half - t]
            source_im = echo_imag[col + half - t]
            for row in range(rows):
                acc_re[row] += kernel[row] * source_re[row]
                acc_im[row] += kernel[row] * source_im[row]
        power = np.empty(rows, dtype=np.float32)
        first = col * rows
        gain = line_gain[col]
        for row in range(rows):
            noise_re, noise_im = unit_pair(mix32(np.uint32(frame_key + np.uint32(first + row))))
            re = (gain * acc_re[row] + noise_amplitude * noise_re) * tgc[row]
            im = (gain * acc_im[row] + noise_amplitude * noise_im) * tgc[row]
            power[row] = re * re + im * im + _TINY_POWER
        log_power = fast_log2(power)
        for row in range(rows):
            grey = grey_scale * log_power[row] + grey_base
            grey = min(max(grey, np.float32(0.0)), np.float32(255.0))
            visible = material[first + row] >= 0
            image[col, row] = grey_map[np.uint8(grey + np.float32(0.5))] if visible else 0
            label_image[col, row] = label[first + row] if visible else 0


@numba.njit(parallel=True, fastmath=VALUE_SAFE_FASTMATH, cache=True)
def smooth_lines(
    lines: np.ndarray,
    material: np.ndarray,
    contact: np.ndarray,
    kernel_axial: np.ndarray,
    kernel_lateral: np.ndarray,
    along: np.ndarray,
    along_weight: np.ndarray,
    out: np.ndarray,
) -> None:
    """`out` = the B-mode `lines` (cols, rows uint8) smoothed by the separable kernels over the
    imaged pixels only (in contact, not air: normalised convolution, so black margins do not
    bleed in), 0 elsewhere. `along`, `along_weight`: (cols, rows) float32 work buffers."""
    cols, rows = lines.shape
    taps = kernel_axial.shape[0]
    half_axial = taps // 2
    half_lateral = kernel_lateral.shape[0] // 2
    for col in numba.prange(cols):
        if not contact[col]:
            along[col, :] = 0.0
            along_weight[col, :] = 0.0
            continue
        # the line padded with zeros (air) at both ends, so every tap runs over all rows: a
        # branch-free loop that vectorises, and adding 0 leaves the sums as they were
        imaged = np.zeros(rows + 2 * half_axial, dtype=np.float32)  # 1 on tissue, 0 in air
        masked = np.zeros_like(imaged)
        for row in range(rows):
            inside = material[col * rows + row] >= 0
            imaged[row + half_axial] = np.float32(1.0) if inside else np.float32(0.0)
            masked[row + half_axial] = np.float32(lines[col, row]) if inside else np.float32(0.0)
        total_line = np.zeros(rows, dtype=np.float32)  # local: no aliasing for the compiler
        weight_line = np.zeros(rows, dtype=np.float32)
        for t in range(taps):
            weight = kernel_axial[t]
            for row in range(rows):
                total_line[row] += weight * masked[row + t]
                weight_line[row] += weight * imaged[row + t]
        along[col, :] = total_line
        along_weight[col, :] = weight_line
    for col in numba.prange(cols):
        if not contact[col]:
            out[col, :] = 0
            continue
        total_line = np.zeros(rows, dtype=np.float32)
        weight_line = np.zeros(rows, dtype=np.float32)
        low = max(0, half_lateral - col)
        high = min(kernel_lateral.shape[0], cols - col + half_lateral)
        for t in range(low, high):
            weight = kernel_lateral[t]
            source = col + t - half_lateral
            for row in range(rows):
                total_line[row] += weight * along[source, row]
                weight_line[row] += weight * along_weight[source, row]
        for row in range(rows):
            if material[col * rows + row] < 0 or weight_line[row] <= 0:
                out[col, row] = 0
            else:
                value = total_line[row] / weight_line[row] + np.float32(0.5)
                out[col, row] = np.uint8(min(value, np.float32(255.0)))


@numba.njit(cache=True, parallel=True)
def transpose_pair(
    first: np.ndarray, second: np.ndarray, first_out: np.ndarray, second_out: np.ndarray
) -> None:
    """`first_out = first.T` and `second_out = second.T` for 2D uint8 arrays, in tiles (numpy's
    strided uint8 copy is several times slower)."""
    cols, rows = first.shape
    tile = 32
    for tile_row in numba.prange((rows + tile - 1) // tile):
        row_end = min(rows, (tile_row + 1) * tile)
        for col_start in range(0, cols, tile):
            col_end = min(cols, col_start + tile)
            for row in range(tile_row * tile, row_end):
                for col in range(col_start, col_end):
                    first_out[row, col] = first[col, row]
                    second_out[row, col] = second[col, row]
