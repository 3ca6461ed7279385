/*
 * lwpr_peer.c -- drives the reference LWPR C library (built separately from
 * ../shared/peers/lwpr, never part of this repository) on a sample stream written by
 * the Rust side, so both implementations see exactly the same numbers.
 * Written for visguide; uses only the public API of lwpr.h.
 *
 * Usage: lwpr_peer INPUT OUTPUT [XML]   (XML: the trained model is written there with
 * lwpr_write_xml at the end)
 * INPUT (little-endian): i32 n_in, n_out, diag_only, meta, update_D, kernel;
 *   f64 meta_rate, penalty, init_alpha, w_gen, w_prune, init_lambda, final_lambda,
 *   tau_lambda, init_S2, add_threshold; f64 init_D[n_in*n_in] (column-major);
 *   f64 norm_in[n_in], norm_out[n_out]; i32 n_train; f64 X[n_train*n_in], Y[n_train*n_out];
 *   i32 n_test; f64 XT[n_test*n_in]; i32 n_ck; i32 ck[n_ck] (ascending update counts).
 * OUTPUT: per checkpoint i32 n_rf[n_out] and f64 yhat[n_test*n_out];
 *   f64 yp[n_train*n_out] (predictions returned by lwpr_update);
 *   f64 update_seconds (update calls only), f64 predictions_per_second.
 */
#define _POSIX_C_SOURCE 199309L
#include <lwpr.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static FILE *in, *out;

static void die(const char *m) { fprintf(stderr, "lwpr_peer: %s\n", m); exit(1); }
static int rd_i(void) { int v; if (fread(&v, sizeof v, 1, in) != 1) die("short input"); return v; }
static double rd_d(void) { double v; if (fread(&v, sizeof v, 1, in) != 1) die("short input"); return v; }
static double *rd_v(long n) {
   double *v = malloc(sizeof(double) * (size_t)(n > 0 ? n : 1));
   if (!v) die("out of memory");
   if (n > 0 && fread(v, sizeof(double), (size_t)n, in) != (size_t)n) die("short input");
   return v;
}
static double now_s(void) {
   struct timespec ts;
   clock_gettime(CLOCK_MONOTONIC, &ts);
   return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv) {
   LWPR_Model model;
   int n_in, n_out, i, k, n_ck, *ck, c;
   long n_train, n_test, t;
   double *D, *X, *Y, *XT, *yp, *yhat, update_s = 0.0, t0, pred_s, sink = 0.0;
   long n_pred = 0;

   if (argc != 3 && argc != 4) die("usage: lwpr_peer INPUT OUTPUT [XML]");
   in = fopen(argv[1], "rb");
   if (!in) die("cannot open input");
   n_in = rd_i();
   n_out = rd_i();
   if (n_in < 1 || n_out < 1) die("bad dimensions");
   if (!lwpr_init_model(&model, n_in, n_out, "peer")) die("init failed");
   model.diag_only = rd_i();
   model.meta = rd_i();
   model.update_D = rd_i();
   model.kernel = rd_i() ? LWPR_BISQUARE_KERNEL : LWPR_GAUSSIAN_KERNEL;
   model.meta_rate = rd_d();
   model.penalty = rd_d();
   if (!lwpr_set_init_alpha(&model, rd_d())) die("bad init_alpha");
   model.w_gen = rd_d();
   model.w_prune = rd_d();
   model.init_lambda = rd_d();
   model.final_lambda = rd_d();
   model.tau_lambda = rd_d();
   model.init_S2 = rd_d();
   model.add_threshold = rd_d();
   D = rd_v((long)n_in * n_in);
   if (!lwpr_set_init_D(&model, D, n_in)) die("bad init_D");
   for (i = 0; i < n_in; i++) model.norm_in[i] = rd_d();
   for (i = 0; i < n_out; i++) model.norm_out[i] = rd_d();
   n_train = rd_i();
   X = rd_v(n_train * n_in);
   Y = rd_v(n_train * n_out);
   n_test = rd_i();
   XT = rd_v(n_test * n_in);
   n_ck = rd_i();
   ck = malloc(sizeof(int) * (size_t)(n_ck > 0 ? n_ck : 1));
   for (c = 0; c < n_ck; c++) ck[c] = rd_i();
   fclose(in);

   out = fopen(argv[2], "wb");
   if (!out) die("cannot open output");
   yp = malloc(sizeof(double) * (size_t)(n_train * n_out + 1));
   yhat = malloc(sizeof(double) * (size_t)(n_test * n_out + 1));
   t = 0;
   for (c = 0; c <= n_ck; c++) {
      long until = (c < n_ck) ? ck[c] : n_train;
      t0 = now_s();
      for (; t < until; t++) {
         if (!lwpr_update(&model, X + t * n_in, Y + t * n_out, yp + t * n_out, NULL)) die("update failed");
      }
      update_s += now_s() - t0;
      if (c == n_ck) break;
      for (k = 0; k < n_out; k++) {
         int nrf = model.sub[k].numRFS;
         fwrite(&nrf, sizeof nrf, 1, out);
      }
      for (i = 0; i < n_test; i++) lwpr_predict(&model, XT + (long)i * n_in, 0.001, yhat + (long)i * n_out, NULL, NULL);
      fwrite(yhat, sizeof(double), (size_t)(n_test * n_out), out);
   }
   fwrite(yp, sizeof(double), (size_t)(n_train * n_out), out);
   t0 = now_s();
   do {
      for (i = 0; i < n_test; i++) {
         lwpr_predict(&model, XT + (long)i * n_in, 0.001, yhat, NULL, NULL);
         sink += yhat[0];
      }
      n_pred += n_test;
      pred_s = now_s() - t0;
   } while (pred_s < 0.25 && n_test > 0);
   if (sink != sink) fprintf(stderr, "lwpr_peer: NaN prediction\n");
   fwrite(&update_s, sizeof update_s, 1, out);
   {
      double pps = n_pred / pred_s;
      fwrite(&pps, sizeof pps, 1, out);
   }
   fclose(out);
   if (argc == 4 && !lwpr_write_xml(&model, argv[3])) die("cannot write the XML file");
   lwpr_free_model(&model);
   return 0;
}
