/*
 * Runs the trigger firmware in simavr (behind --simulate and for the tests).
 *
 * usage: simavr_harness FIRMWARE.elf
 *
 * UART0 is bridged to a pseudo-terminal whose path is printed as "PTY <path>".
 * Commands on stdin, one per line:
 *   p   one SLM master pulse on D2 (100 us high), answered "DONE p" 100 us later
 *   r   reset the MCU (as a brown-out would), answered "DONE r"
 * Every change of the camera output D4 is printed as "OUT 0" or "OUT 1".
 * The harness exits when stdin closes.
 *
 * The bridge lives in the simulation loop rather than in libsimavrparts' uart_pty:
 * simavr is single-threaded, and uart_pty (1.6) raises UART input from its own
 * thread, which races the cycle timers and can stall reception for good.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <pty.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"

#define F_CPU 16000000
#define PULSE_CYCLES 1600            /* 100 us high, then at least 100 us low */
#define BYTE_CYCLES (F_CPU / 11520)  /* one byte at 115200 baud, 8N1 */

static volatile int pending_pulses;
static volatile int pending_resets;
static volatile int quit;
static int master = -1;
static int uart_full;

static void *read_commands(void *unused)
{
    (void)unused;
    char line[64];
    while (fgets(line, sizeof line, stdin)) {
        if (line[0] == 'p') {
            __atomic_add_fetch(&pending_pulses, 1, __ATOMIC_SEQ_CST);
        } else if (line[0] == 'r') {
            __atomic_add_fetch(&pending_resets, 1, __ATOMIC_SEQ_CST);
        }
    }
    __atomic_store_n(&quit, 1, __ATOMIC_SEQ_CST);
    return NULL;
}

static void say(const char *text)
{
    fputs(text, stdout);
    fflush(stdout);
}

static void output_changed(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    say(value ? "OUT 1\n" : "OUT 0\n");
}

static void uart_sent(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    uint8_t byte = (uint8_t)value;
    while (write(master, &byte, 1) < 0 && errno == EAGAIN) {
        usleep(100);
    }
}

static void uart_xoff(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    uart_full = value != 0;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s FIRMWARE.elf\n", argv[0]);
        return 2;
    }
    elf_firmware_t firmware;
    memset(&firmware, 0, sizeof firmware);
    if (elf_read_firmware(argv[1], &firmware) != 0) {
        fprintf(stderr, "cannot read firmware %s\n", argv[1]);
        return 1;
    }
    /* The firmware carries no simavr MCU section: name the part here. */
    strcpy(firmware.mmcu, "atmega328p");
    firmware.frequency = F_CPU;
    avr_t *avr = avr_make_mcu_by_name(firmware.mmcu);
    if (!avr) {
        fprintf(stderr, "simavr does not know %s\n", firmware.mmcu);
        return 1;
    }
    avr_init(avr);
    avr_load_firmware(avr, &firmware);

    char slave[256];
    int slave_fd;
    struct termios raw;
    if (openpty(&master, &slave_fd, slave, NULL, NULL) < 0) {
        perror("openpty");
        return 1;
    }
    tcgetattr(slave_fd, &raw);
    cfmakeraw(&raw);
    tcsetattr(slave_fd, TCSANOW, &raw);
    tcgetattr(master, &raw);
    cfmakeraw(&raw);
    tcsetattr(master, TCSANOW, &raw);
    fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);

    /* Keep the firmware's output off our stdout: it goes to the pty only. */
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~AVR_UART_FLAG_STDIO;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_t *uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            uart_sent, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            uart_xoff, NULL);

    avr_irq_t *pulse_pin = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), IOPORT_IRQ_PIN2);
    avr_irq_t *camera_pin = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), IOPORT_IRQ_PIN4);
    avr_irq_register_notify(camera_pin, output_changed, NULL);
    avr_raise_irq(pulse_pin, 0);

    printf("PTY %s\n", slave);
    fflush(stdout);

    pthread_t reader;
    pthread_create(&reader, NULL, read_commands, NULL);

    uint8_t rx[256];
    ssize_t rx_len = 0, rx_done = 0;
    avr_cycle_count_t next_byte = 0;
    int pulse_phase = 0; /* 0 idle, 1 high, 2 low until the edge is handled */
    avr_cycle_count_t pulse_end = 0;
    for (;;) {
        int state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            fprintf(stderr, "simavr stopped (state %d)\n", state);
            return 1;
        }
        if (avr->cycle >= next_byte) {
            /* Host -> MCU, paced at the line rate so the UART's FIFO never overflows. */
            next_byte = avr->cycle + BYTE_CYCLES;
            if (rx_done == rx_len) {
                rx_len = read(master, rx, sizeof rx);
                rx_done = 0;
                if (rx_len < 0) {
                    rx_len = 0;
                }
            }
            if (rx_done < rx_len && !uart_full) {
                avr_raise_irq(uart_in, rx[rx_done++]);
            }
        }
        if (pulse_phase == 1 && avr->cycle >= pulse_end) {
            avr_raise_irq(pulse_pin, 0);
            pulse_phase = 2;
            pulse_end = avr->cycle + PULSE_CYCLES;
        } else if (pulse_phase == 2 && avr->cycle >= pulse_end) {
            /* Answer only once the firmware has certainly seen the falling edge. */
            pulse_phase = 0;
            say("DONE p\n");
        } else if (pulse_phase == 0 && __atomic_load_n(&pending_pulses, __ATOMIC_SEQ_CST) > 0) {
            __atomic_sub_fetch(&pending_pulses, 1, __ATOMIC_SEQ_CST);
            avr_raise_irq(pulse_pin, 1);
            pulse_phase = 1;
            pulse_end = avr->cycle + PULSE_CYCLES;
        }
        if (pulse_phase == 0 && __atomic_load_n(&pending_resets, __ATOMIC_SEQ_CST) > 0) {
            __atomic_sub_fetch(&pending_resets, 1, __ATOMIC_SEQ_CST);
            avr_reset(avr);
            say("DONE r\n");
        }
        if (__atomic_load_n(&quit, __ATOMIC_SEQ_CST)) {
            return 0;
        }
    }
}
