/* _core_batch.h - batched host entry points (see _core_batch.c).  Also the
 * cffi cdef: keep it free of preprocessor conditionals. */
#define INC_ATT_COLS 8
#define INC_SURVEY_COLS 14

void inc_batch_mul32_q31(const int32_t *a, const int32_t *b, int32_t *out, uint8_t *sat, size_t n);
void inc_batch_asr32_rnd(const int32_t *x, const uint8_t *sh, int32_t *out, size_t n);
void inc_batch_div_frac_q20(const uint32_t *num, const uint32_t *den, uint32_t *out, size_t n);
void inc_batch_sqrt_u32_q8(const uint32_t *x, uint32_t *out, size_t n);
void inc_batch_atan2_q16(const int32_t *y, const int32_t *x, int32_t *out, size_t n);
void inc_batch_att(const int32_t *g, const int32_t *b, int32_t *out, size_t n);
void inc_batch_survey_temp(const int32_t *acc, const int32_t *mag, const int32_t *temp_q6,
                           const corr_cal_t *cal, size_t ncal, int32_t *out, size_t n);
void inc_batch_qc(const int32_t *att /* n x INC_ATT_COLS */, const qc_ref_t *ref, uint8_t *out, size_t n);
void inc_batch_survey(const int32_t *acc, const int32_t *mag, const corr_cal_t *cal, size_t ncal,
                      int32_t *out, size_t n);
