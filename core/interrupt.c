/* SIGINT/SIGTERM as a polled flag (core/interrupt.h). */
#include "core/interrupt.h"

#include <signal.h>
#include <string.h>

#include "core/error.h"

static volatile sig_atomic_t received_signal;

static void on_signal(int number)
{
    received_signal = number;
}

void interrupt_install(void)
{
    struct sigaction action;
    memset(&action, 0, sizeof action);
    action.sa_handler = on_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, NULL);
    sigaction(SIGTERM, &action, NULL);
}

int interrupt_status(void)
{
    if (received_signal == SIGINT)
        return SC_EINT;
    if (received_signal == SIGTERM)
        return SC_ETERM;
    return SC_OK;
}
