/*
 * lwpr_xml_peer.c -- reads an XML model file with the reference LWPR C library's
 * lwpr_read_xml (built separately from ../shared/peers/lwpr with libexpat, never part of
 * this repository), predicts on test points, then goes on training it, so the Rust side can
 * compare what both implementations make of the same file.
 * Written for visguide; uses only the public API of lwpr.h and lwpr_xml.h.
 *
 * Usage: lwpr_xml_peer MODEL.xml INPUT OUTPUT
 * INPUT (little-endian): i32 n_test; f64 XT[n_test*n_in]; i32 n_train;
 *   f64 X[n_train*n_in], Y[n_train*n_out].
 * OUTPUT: i32 n_in, n_out; i32 n_rf[n_out] (as read); per test point f64 y[n_out],
 *   conf[n_out], J[n_out*n_in] (column-major: J[i + j*n_out] = dy_i/dx_j); f64 yp[n_train*n_out]
 *   (predictions returned by lwpr_update); i32 n_rf[n_out] and f64 y[n_test*n_out] after training.
 * Exit status 2 when lwpr_read_xml reports errors (their count and messages on stderr).
 */
#include <lwpr.h>
#include <lwpr_xml.h>
#include <stdio.h>
#include <stdlib.h>

static FILE *in, *out;

static void die(const char *m) { fprintf(stderr, "lwpr_xml_peer: %s\n", m); exit(1); }
static int rd_i(void) { int v; if (fread(&v, sizeof v, 1, in) != 1) die("short input"); return v; }
static double *rd_v(long n) {
   double *v = malloc(sizeof(double) * (size_t)(n > 0 ? n : 1));
   if (!v) die("out of memory");
   if (n > 0 && fread(v, sizeof(double), (size_t)n, in) != (size_t)n) die("short input");
   return v;
}
static void wr_rfs(const LWPR_Model *model) {
   int k;
   for (k = 0; k < model->nOut; k++) fwrite(&model->sub[k].numRFS, sizeof(int), 1, out);
}

int main(int argc, char **argv) {
   LWPR_Model model;
   int n_in, n_out, warnings = 0, errors;
   long n_test, n_train, i;
   double *XT, *X, *Y, *y, *conf, *J;

   if (argc != 4) die("usage: lwpr_xml_peer MODEL.xml INPUT OUTPUT");
   errors = lwpr_read_xml(&model, argv[1], &warnings);
   if (errors != 0) {
      fprintf(stderr, "lwpr_xml_peer: lwpr_read_xml reported %d errors\n", errors);
      return 2;
   }
   n_in = model.nIn;
   n_out = model.nOut;
   in = fopen(argv[2], "rb");
   if (!in) die("cannot open input");
   n_test = rd_i();
   XT = rd_v(n_test * n_in);
   n_train = rd_i();
   X = rd_v(n_train * n_in);
   Y = rd_v(n_train * n_out);
   fclose(in);

   out = fopen(argv[3], "wb");
   if (!out) die("cannot open output");
   fwrite(&n_in, sizeof n_in, 1, out);
   fwrite(&n_out, sizeof n_out, 1, out);
   wr_rfs(&model);
   y = malloc(sizeof(double) * (size_t)(n_out * (n_test + n_train + 1)));
   conf = malloc(sizeof(double) * (size_t)n_out);
   J = malloc(sizeof(double) * (size_t)(n_out * n_in));
   if (!y || !conf || !J) die("out of memory");
   for (i = 0; i < n_test; i++) {
      lwpr_predict(&model, XT + i * n_in, 0.001, y, conf, NULL);
      fwrite(y, sizeof(double), (size_t)n_out, out);
      fwrite(conf, sizeof(double), (size_t)n_out, out);
      lwpr_predict_J(&model, XT + i * n_in, 0.001, y, J);
      fwrite(J, sizeof(double), (size_t)(n_out * n_in), out);
   }
   for (i = 0; i < n_train; i++) {
      if (!lwpr_update(&model, X + i * n_in, Y + i * n_out, y + i * n_out, NULL)) die("update failed");
   }
   fwrite(y, sizeof(double), (size_t)(n_train * n_out), out);
   wr_rfs(&model);
   for (i = 0; i < n_test; i++) {
      lwpr_predict(&model, XT + i * n_in, 0.001, y, NULL, NULL);
      fwrite(y, sizeof(double), (size_t)n_out, out);
   }
   fclose(out);
   lwpr_free_model(&model);
   return 0;
}
