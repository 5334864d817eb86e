/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the per-DoF networks as a quantised int8 interpreter.
 *
 * A model is a flat weights file (format: docs/weights-format.md, written by
 * tools/tinyvo_tools/nnfmt.py) holding up to six branches, one per degree of freedom. Each branch is
 * a small fully connected network (paper size: n_in -> 256 -> 32 -> 32 -> 1) that reads a subset of the
 * front end's features (enum tvo_feature), normalises them with float32 scale/offset stored in the
 * model, quantises them to int8 and runs int8 x int8 -> int32 fully connected layers, requantised with a
 * fixed-point multiplier and shift, and nonlinear activations as 256-entry int8 lookup tables. The last
 * layer of a branch is dequantised to float32 and de-normalised to the DoF's unit.
 *
 * Results are bit-exact with the NumPy reference (tinyvo_tools.nnfmt.reference_run) on any IEEE-754
 * platform that evaluates float expressions in float (FLT_EVAL_METHOD 0) and does not fuse
 * multiply-adds (the build uses -ffp-contract=off).
 *
 * Memory: tvo_nn_required_size() tells the caller how many bytes tvo_nn_load() needs; the loader copies
 * everything it uses (weights converted to native layout, biases with the input zero point folded in,
 * requantisation parameters, tables) into that memory, so the file buffer may be freed after loading
 * and need not be aligned. Nothing is allocated afterwards. */
#ifndef TINYVO_NN_H
#define TINYVO_NN_H

#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- features: the VO front end fills a float array indexed by these ids -------------------- */
enum tvo_feature {
    TVO_FEAT_RX = 0,
    TVO_FEAT_RY,
    TVO_FEAT_RZ, /* raw VO relative rotation prev->cur as rotation vector, rad */
    TVO_FEAT_TX,
    TVO_FEAT_TY,
    TVO_FEAT_TZ,           /* raw VO unit translation direction (camera frame of prev) */
    TVO_FEAT_INLIER_RATIO, /* inliers / tracked points, 0..1 */
    TVO_FEAT_PARALLAX_DEG, /* median rotation-compensated parallax, degrees */
    TVO_FEAT_TRACKS,       /* tracked points / 1000 */
    TVO_FEAT_DT,           /* seconds since previous frame */
    TVO_FEAT_ROT_ONLY,     /* 1 if the front end reported rotation-only, else 0 */
    TVO_FEAT_COUNT
};
/* Identifies the list above. A model whose layout id differs is refused with TVO_ERR_MISMATCH. */
#define TVO_FEAT_LAYOUT_ID 1u

/* outputs: index 0..5 = tx ty tz (metres, T_prev_cur translation in the prev camera frame), rx ry rz
 * (rotation vector of R_prev_cur, rad); index 6 (TVO_NN_STEP, tvo_nn_run_all only) = the metric length
 * |t| of the step (metres), which tvo_vo_refine applies to the raw VO unit translation. */
enum tvo_nn_dof { TVO_NN_TX = 0, TVO_NN_TY, TVO_NN_TZ, TVO_NN_RX, TVO_NN_RY, TVO_NN_RZ, TVO_NN_DOF_COUNT };
#define TVO_NN_STEP 6      /* output index of the step length */
#define TVO_NN_OUT_COUNT 7 /* outputs of tvo_nn_run_all */

/* Branch DoF codes of the file (docs/weights-format.md): 0..5 the DoFs above; since version 1.1 also a
 * step-length branch, whose value is |t| in metres (code 6) or ln |t| (code 7; the interpreter returns
 * exp of it, clamped to [TVO_NN_LOG_STEP_MIN, TVO_NN_LOG_STEP_MAX] first, as the step). A model holds at
 * most one step-length branch and then no tx ty tz branch. */
#define TVO_NN_CODE_STEP 6u
#define TVO_NN_CODE_LOG_STEP 7u
#define TVO_NN_CODE_COUNT 8u
#define TVO_NN_LOG_STEP_MIN (-16.0f)
#define TVO_NN_LOG_STEP_MAX 8.0f

/* ---- format constants (docs/weights-format.md) ------------------------------------------------ */
#define TVO_NN_MAGIC 0x4E4E5654u /* bytes "TVNN" read as a little-endian u32 */
#define TVO_NN_VERSION_MAJOR 1u  /* a file with another major version is refused */
#define TVO_NN_VERSION_MINOR 1u  /* files with a higher minor version are accepted; 1: step-length codes */
#define TVO_NN_HEADER_SIZE 64u
#define TVO_NN_BRANCH_ENTRY_SIZE 48u
#define TVO_NN_INPUT_ENTRY_SIZE 12u
#define TVO_NN_LAYER_ENTRY_SIZE 64u
#define TVO_NN_PAYLOAD_ALIGN 16u /* weight blocks; int32/float arrays are 4-aligned, tables 16 */

/* Limits a model must respect (overridable on the compiler command line). */
#ifndef TVO_NN_MAX_LAYERS
#define TVO_NN_MAX_LAYERS 8 /* layers per branch */
#endif
#ifndef TVO_NN_MAX_WIDTH
#define TVO_NN_MAX_WIDTH 4096 /* inputs or outputs of one layer; keeps int32 sums exact */
#endif
#ifndef TVO_NN_MAX_FILE_SIZE
#define TVO_NN_MAX_FILE_SIZE (64u * 1024u * 1024u)
#endif

/* Activation codes of the file (per layer). */
typedef enum tvo_nn_act {
    TVO_NN_ACT_NONE = 0,
    TVO_NN_ACT_RELU = 1,
    TVO_NN_ACT_LEAKY_RELU = 2, /* slope 0.01 (PyTorch default) */
    TVO_NN_ACT_ELU = 3,        /* alpha 1 */
    TVO_NN_ACT_SELU = 4,
    TVO_NN_ACT_TANH = 5,
    TVO_NN_ACT_SIGMOID = 6,
    TVO_NN_ACT_COUNT
} tvo_nn_act;

/* Layer output kinds. */
#define TVO_NN_OUT_S8 0u  /* requantised int8 (hidden layers) */
#define TVO_NN_OUT_F32 1u /* dequantised float32 (the last layer of a branch, 1 output) */

/* A loaded model. Lives in the memory handed to tvo_nn_load(); opaque. */
typedef struct tvo_nn tvo_nn;

/* Validates the file completely (see tvo_nn_load for the statuses) and returns in *bytes the memory
 * tvo_nn_load() needs for it (alignment slack included). Cost: one pass over the file (CRC32). */
TVO_API tvo_status tvo_nn_required_size(const void *file, size_t file_size, size_t *bytes);

/* Validates a weights file and builds a runnable model in [mem, mem + mem_size). On success *nn points
 * into mem; the file buffer is not referenced afterwards (it may be freed, it need not be aligned).
 * Nothing is trusted: every check happens before anything is copied or run. Statuses:
 *   TVO_ERR_NULL       nn, file, mem or bytes is NULL
 *   TVO_ERR_SIZE       file shorter than the header, header's file_size differs from file_size
 *                      (truncated or trailing bytes), file larger than TVO_NN_MAX_FILE_SIZE, a count
 *                      of branches/inputs/layers/units that is 0 or above its limit, entry sizes wrong
 *   TVO_ERR_FORMAT     wrong magic; layer sizes that do not chain; zero points that do not chain;
 *                      a duplicated DoF; a step-length branch (code 6 or 7) in a file of minor version 0,
 *                      beside a tx, ty or tz branch, or beside another step-length branch; a misaligned
 *                      offset; non-zero reserved fields; a float-output
 *                      layer that is not the last or a last layer that is not float output with 1 unit;
 *                      a LUT given for NONE or missing for another activation
 *   TVO_ERR_VERSION    major version differs from TVO_NN_VERSION_MAJOR
 *   TVO_ERR_CRC        CRC32 of bytes [16, file_size) differs from the header's
 *   TVO_ERR_MISMATCH   feature layout id or feature count differs from the compiled TVO_FEAT_LAYOUT_ID
 *   TVO_ERR_RANGE      an offset or table past the end of the file or overlapping the header; a
 *                      feature id or DoF code out of range (>= TVO_NN_CODE_COUNT); zero point outside [-128, 127]; requantisation
 *                      multiplier outside [2^30, 2^31) or shift outside [1, 62]; a bias or a worst-case
 *                      sum that could overflow int32
 *   TVO_ERR_UNSUPPORTED unknown activation code or layer output kind
 *   TVO_ERR_NOT_FINITE a scale or offset that is NaN/inf, or a scale that is zero or negative
 *   TVO_ERR_NO_MEMORY  mem_size below tvo_nn_required_size()
 * Cost: one CRC pass plus one copy of the weights. */
TVO_API tvo_status tvo_nn_load(tvo_nn **nn, const void *file, size_t file_size, void *mem, size_t mem_size);

/* Runs every branch. features[TVO_FEAT_COUNT] as in enum tvo_feature; out[6] receives tx ty tz rx ry
 * rz for the DoFs in tvo_nn_output_mask(); the others are set to NaN. No allocation; uses scratch
 * space inside the model's memory, so one tvo_nn must not run on two threads at once.
 * TVO_ERR_NULL for NULL pointers; TVO_ERR_NOT_FINITE if a feature that some branch reads is NaN or
 * infinite, or if an output overflows float (possible with extreme but finite scales in the file);
 * out is then all NaN. On TVO_OK every provided output is finite.
 * Cost: sum over layers of n_in * n_out MACs (tvo_nn_macs()). */
TVO_API tvo_status tvo_nn_run(const tvo_nn *nn, const float features[TVO_FEAT_COUNT], float out[6]);

/* Same as tvo_nn_run with the seven outputs: out[TVO_NN_STEP] is the step length (m) of a model with a
 * step-length branch (code 6: the branch's value, any sign; code 7: exp of the clamped value, > 0), NaN
 * otherwise. tvo_nn_run gives the first six of these. */
TVO_API tvo_status tvo_nn_run_all(const tvo_nn *nn, const float features[TVO_FEAT_COUNT],
                                  float out[TVO_NN_OUT_COUNT]);

/* Bit d (0..6) set when the model provides output d (bit 6: a step-length branch). 0 for NULL. */
TVO_API int32_t tvo_nn_output_mask(const tvo_nn *nn);

/* Multiply-accumulates per tvo_nn_run() call. 0 for NULL. */
TVO_API uint32_t tvo_nn_macs(const tvo_nn *nn);

/* Number of branches, and the activation of branch i's first hidden layer (TVO_NN_ACT_NONE for a
 * NULL model or i out of range): for reports. */
TVO_API int32_t tvo_nn_branch_count(const tvo_nn *nn);
TVO_API tvo_nn_act tvo_nn_branch_activation(const tvo_nn *nn, int32_t i);

/* CRC-32 (IEEE 802.3: reflected polynomial 0xEDB88320, init and final xor 0xFFFFFFFF), as zlib's
 * crc32(). crc is the value of the previous call, 0 to start. */
TVO_API uint32_t tvo_nn_crc32(uint32_t crc, const void *data, size_t size);

/* ---- kernels (CMSIS-NN style; one per file; usable on their own) ------------------------------ */

/* The one requantisation rounding mode: round(acc * mult / 2^shift) with ties toward +infinity,
 * i.e. floor((acc * mult + 2^(shift-1)) / 2^shift), computed exactly in 64 bits. Valid for any int32
 * acc, mult in [2^30, 2^31) and shift in [1, 62] (the loader enforces these). */
static inline int32_t tvo_nn_requantize(int32_t acc, int32_t mult, int32_t shift)
{
    int64_t v = (int64_t)acc * (int64_t)mult + ((int64_t)1 << (shift - 1));
    /* floor division by 2^shift without relying on the implementation-defined >> of negatives */
    int64_t q = v >= 0 ? (v >> shift) : -1 - ((-1 - v) >> shift);
    return (int32_t)q;
}

/* Fully connected int8 layer: for o < n_out,
 *   acc = bias[o] + sum_i w[o * n_in + i] * x[i]
 *   y[o] = clamp(tvo_nn_requantize(acc, mult[o], shift[o]) + out_zp, -128, 127)
 * x are raw int8 activations: fold the input zero point into bias (bias - in_zp * sum_i w[o][i]).
 * The caller guarantees the sums fit int32 (the loader checks the worst case). Cost n_in * n_out MACs. */
TVO_API void tvo_nn_fc_s8(const int8_t *x, const int8_t *w, const int32_t *bias, const int32_t *mult,
                          const int32_t *shift, int32_t out_zp, int32_t n_in, int32_t n_out, int8_t *y);

/* Same as tvo_nn_fc_s8 with column-major weights wt[i * n_out + o]: faster for short inputs (the
 * loader uses it when n_in < TVO_NN_COLS_MAX_IN), same results. */
TVO_API void tvo_nn_fc_s8_cols(const int8_t *x, const int8_t *wt, const int32_t *bias, const int32_t *mult,
                               const int32_t *shift, int32_t out_zp, int32_t n_in, int32_t n_out, int8_t *y);
#ifndef TVO_NN_COLS_MAX_IN
#define TVO_NN_COLS_MAX_IN 16
#endif

/* Fully connected int8 layer with float output: y[o] = (float)acc * scale[o], acc as above. */
TVO_API void tvo_nn_fc_s8_f32(const int8_t *x, const int8_t *w, const int32_t *bias, const float *scale,
                              int32_t n_in, int32_t n_out, float *y);

/* Lookup-table activation in place: x[i] = lut[x[i] + 128]. */
TVO_API void tvo_nn_lut_s8(int8_t *x, int32_t n, const int8_t lut[256]);

/* Input stage of a branch: for i < n, with f = features[ids[i]] (float32 arithmetic throughout):
 *   t = rint((f * norm_scale[i] + norm_offset[i]) / in_scale)   (ties to even)
 *   x[i] = clamp(t + in_zp, -128, 127)
 * TVO_ERR_NOT_FINITE if a read feature is NaN or infinite. */
TVO_API tvo_status tvo_nn_quantize_input_f32(const float *features, const uint8_t *ids,
                                             const float *norm_scale, const float *norm_offset,
                                             float in_scale, int32_t in_zp, int32_t n, int8_t *x);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_NN_H */
