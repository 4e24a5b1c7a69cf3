/* test_h5fields.c — common/h5fields.c inside a host process that uses HDF5
 * itself: the field writer (the fluid FMU's) reports its failures with their
 * cause and prints nothing through HDF5, and leaves the host's own HDF5 error
 * printing as it found it. It turned the printing off for the whole process
 * at its first open: a host (an FMI master writing its own HDF5 files) then
 * lost HDF5's messages for its own calls. */
#include "scene_tests.h"

#include "../../common/h5fields.h"

#include <CUnit/CUnit.h>
#include <hdf5.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* the host's handler: counts what HDF5 would print */
static herr_t host_prints(hid_t stack, void *data)
{
    (void)stack;
    ++*(int *)data;
    return 0;
}

static int host_handler_is_in_place(const int *counter)
{
    H5E_auto2_t fn = NULL;
    void *data = NULL;
    H5Eget_auto2(H5E_DEFAULT, &fn, &data);
    return fn == host_prints && data == counter;
}

static void collect(void *ctx, status_t level, const char *category, const char *msg)
{
    (void)level, (void)category;
    snprintf(ctx, 512, "%s", msg);
}

static void test_host_error_printing_is_left_as_it_was(void)
{
    int printed = 0;
    H5E_auto2_t old_fn = NULL;
    void *old_data = NULL;
    H5Eget_auto2(H5E_DEFAULT, &old_fn, &old_data);
    H5Eset_auto2(H5E_DEFAULT, host_prints, &printed);

    char dir[] = "/tmp/agglo-h5fields-XXXXXX", path[512], msg[512] = "";
    CU_ASSERT_FATAL(mkdtemp(dir) != NULL);
    snprintf(path, sizeof path, "%s/f.h5", dir);
    const log_t log = {collect, msg};
    const int n[3] = {4, 3, 2};
    double rho[24], u[72];
    unsigned char flags[24];
    for (int i = 0; i < 24; i++) {
        rho[i] = 1.0 + 0.01 * i;
        u[3 * i] = u[3 * i + 1] = u[3 * i + 2] = 1e-3 * i;
        flags[i] = 0;
    }
    h5fields_t *w = NULL;
    CU_ASSERT_EQUAL(h5fields_open(path, n, 1e-4, NULL, &log, &w), STATUS_OK);
    CU_ASSERT(host_handler_is_in_place(&printed));
    CU_ASSERT_EQUAL(h5fields_write(w, 0, 0.0, rho, u, flags), STATUS_OK);
    CU_ASSERT(host_handler_is_in_place(&printed));
    CU_ASSERT_EQUAL(h5fields_close(w), STATUS_OK);
    CU_ASSERT(host_handler_is_in_place(&printed));

    /* a failure inside the writer: reported through the log, HDF5 prints nothing */
    char bad[600];
    snprintf(bad, sizeof bad, "%s/no/such/folder/f.h5", dir);
    w = NULL;
    CU_ASSERT_NOT_EQUAL(h5fields_open(bad, n, 1e-4, NULL, &log, &w), STATUS_OK);
    CU_ASSERT_PTR_NULL(w);
    CU_ASSERT(strstr(msg, "no/such/folder") != NULL);
    CU_ASSERT_EQUAL(printed, 0);
    CU_ASSERT(host_handler_is_in_place(&printed));

    /* and the host's own failing call still reaches its handler */
    hid_t f = H5Fopen(bad, H5F_ACC_RDONLY, H5P_DEFAULT);
    CU_ASSERT(f < 0);
    CU_ASSERT(printed >= 1);

    H5Eset_auto2(H5E_DEFAULT, old_fn, old_data);
    unlink(path);
    char xmf[520];
    snprintf(xmf, sizeof xmf, "%s/f.xmf", dir);
    unlink(xmf);
    rmdir(dir);
}

void h5fields_register_tests(void)
{
    CU_pSuite s = CU_add_suite("h5fields", NULL, NULL);
    CU_add_test(s, "the host's HDF5 error printing is left as it was; the writer's failures go to its log",
                test_host_error_printing_is_left_as_it_was);
}
