/*
 * SASSI exposure trigger for an ATmega328P (Arduino Uno, 16 MHz).
 *
 * The SLM's master pulse enters on D2 (PD2, pin-change interrupt PCINT18; simavr 1.6,
 * which the tests run this on, stalls UART reception with INT0 in any-change mode).
 * Every pulse is counted; while the trigger is armed, every n-th pulse is copied to
 * the camera outputs D4 (PD4, spectral camera) and D5 (PD5, guide camera) for as long
 * as the input stays high, so the cameras expose only while a pattern is on display.
 * D13 (PB5, the on-board LED) shows the armed state.
 *
 * Line protocol on UART0 (115200 baud, 8N1, lines end with "\n"; "\r" is ignored).
 * Every command gets exactly one reply line:
 *
 *   ID?        -> "SASSI-TRIGGER 1 ATMEGA328P"
 *   DIV <n>    -> "OK"            pass every n-th pulse, 1 <= n <= 65535
 *   DIV?       -> "DIV <n>"
 *   ARM        -> "OK"            start passing pulses (the n-th pulse after ARM is the first)
 *   DISARM     -> "OK"            stop passing pulses (they are still counted)
 *   CNT?       -> "CNT <received> <passed>"
 *   STATE?     -> "STATE <armed 0|1> <n>"
 *   RST        -> "OK"            zero both counters
 *   anything else -> "ERR <reason>"
 *
 * After a reset the device prints "READY SASSI-TRIGGER 1" once.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <util/atomic.h>

#ifndef BAUD
#define BAUD 115200
#endif
#define BAUD_TOL 3
#include <util/setbaud.h>

#define PULSE_IN PD2
#define CAMERA_OUT ((1 << PD4) | (1 << PD5))
#define LED PB5
#define LINE_MAX 32
#define RX_SIZE 64 /* power of two */

static volatile uint32_t received;
static volatile uint32_t passed;
static volatile uint16_t divider = 1;
static volatile uint16_t phase;
static volatile uint8_t armed;

static volatile uint8_t rx_buf[RX_SIZE];
static volatile uint8_t rx_head;
static uint8_t rx_tail;

ISR(PCINT2_vect)
{
    if (PIND & (1 << PULSE_IN)) {
        received++;
        if (armed && ++phase >= divider) {
            phase = 0;
            passed++;
            PORTD |= CAMERA_OUT;
        }
    } else {
        PORTD &= (uint8_t)~CAMERA_OUT;
    }
}

ISR(USART_RX_vect)
{
    uint8_t byte = UDR0;
    uint8_t next = (uint8_t)((rx_head + 1) & (RX_SIZE - 1));
    if (next != rx_tail) { /* a full buffer drops the byte; the line then fails */
        rx_buf[rx_head] = byte;
        rx_head = next;
    }
}

static void uart_init(void)
{
    UBRR0H = UBRRH_VALUE;
    UBRR0L = UBRRL_VALUE;
#if USE_2X
    UCSR0A |= (1 << U2X0);
#else
    UCSR0A &= (uint8_t)~(1 << U2X0);
#endif
    UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
    UCSR0C = (1 << UCSZ01) | (1 << UCSZ00);
}

static void put_char(char c)
{
    while (!(UCSR0A & (1 << UDRE0))) {
    }
    UDR0 = (uint8_t)c;
}

static void put_str(const char *s)
{
    while (*s) {
        put_char(*s++);
    }
}

static void put_u32(uint32_t value)
{
    char text[11];
    ultoa(value, text, 10);
    put_str(text);
}

static void set_armed(uint8_t on)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        phase = 0;
        armed = on;
    }
    if (on) {
        PORTB |= (1 << LED);
    } else {
        PORTB &= (uint8_t)~(1 << LED);
        PORTD &= (uint8_t)~CAMERA_OUT;
    }
}

/* Parse a decimal in 1..65535 that fills the whole string; 0 when invalid. */
static uint16_t parse_divider(const char *s)
{
    uint32_t value = 0;
    if (*s == '\0') {
        return 0;
    }
    for (; *s; s++) {
        if (*s < '0' || *s > '9') {
            return 0;
        }
        value = value * 10 + (uint32_t)(*s - '0');
        if (value > 65535UL) {
            return 0;
        }
    }
    return (uint16_t)value;
}

static void handle(char *line)
{
    for (char *c = line; *c; c++) {
        if (*c >= 'a' && *c <= 'z') {
            *c = (char)(*c - 'a' + 'A');
        }
    }
    if (strcmp(line, "ID?") == 0) {
        put_str("SASSI-TRIGGER 1 ATMEGA328P\n");
    } else if (strcmp(line, "ARM") == 0) {
        set_armed(1);
        put_str("OK\n");
    } else if (strcmp(line, "DISARM") == 0) {
        set_armed(0);
        put_str("OK\n");
    } else if (strcmp(line, "DIV?") == 0) {
        put_str("DIV ");
        put_u32(divider);
        put_char('\n');
    } else if (strncmp(line, "DIV ", 4) == 0) {
        uint16_t n = parse_divider(line + 4);
        if (n == 0) {
            put_str("ERR divider must be an integer in 1..65535\n");
        } else {
            ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
            {
                divider = n;
                phase = 0;
            }
            put_str("OK\n");
        }
    } else if (strcmp(line, "CNT?") == 0) {
        uint32_t rx, tx;
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
        {
            rx = received;
            tx = passed;
        }
        put_str("CNT ");
        put_u32(rx);
        put_char(' ');
        put_u32(tx);
        put_char('\n');
    } else if (strcmp(line, "STATE?") == 0) {
        put_str(armed ? "STATE 1 " : "STATE 0 ");
        put_u32(divider);
        put_char('\n');
    } else if (strcmp(line, "RST") == 0) {
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
        {
            received = 0;
            passed = 0;
            phase = 0;
        }
        put_str("OK\n");
    } else {
        put_str("ERR unknown command\n");
    }
}

int main(void)
{
    char line[LINE_MAX];
    uint8_t len = 0;
    uint8_t overflow = 0;

    DDRD |= CAMERA_OUT;
    PORTD &= (uint8_t)~CAMERA_OUT;
    DDRB |= (1 << LED);
    DDRD &= (uint8_t)~(1 << PULSE_IN);
    PCMSK2 = (1 << PCINT18); /* D2 on any change: rising counts, falling ends the gate */
    PCICR = (1 << PCIE2);
    uart_init();
    set_sleep_mode(SLEEP_MODE_IDLE);
    sei();
    put_str("READY SASSI-TRIGGER 1\n");

    for (;;) {
        cli();
        if (rx_tail == rx_head) {
            sleep_enable();
            sei(); /* the instruction after SEI runs first: no wake-up is lost */
            sleep_cpu();
            sleep_disable();
        }
        sei();
        while (rx_tail != rx_head) {
            char c = (char)rx_buf[rx_tail];
            rx_tail = (uint8_t)((rx_tail + 1) & (RX_SIZE - 1));
            if (c == '\r') {
                continue;
            }
            if (c != '\n') {
                if (len < LINE_MAX - 1) {
                    line[len++] = c;
                } else {
                    overflow = 1;
                }
                continue;
            }
            line[len] = '\0';
            if (overflow) {
                put_str("ERR line too long\n");
            } else if (len > 0) {
                handle(line);
            }
            len = 0;
            overflow = 0;
        }
    }
}
